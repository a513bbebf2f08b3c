#include "pipeline/calibrate_pipeline.h"
#include "pipeline/saccade_study.h"
#include "pipeline/settling_study.h"
#include "pipeline/tag_study.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <tuple>

#include <Eigen/Cholesky>

#include <opencv2/core/utility.hpp>

#include "calib/observation.h"
#include "calib/observation_io.h"
#include "calib/trial_status.h"
#include "fitting/fit_points.h"
#include "fitting/head_gauge.h"
#include "fitting/limits_eval.h"
#include "fitting/ploop_analysis.h"
#include "fitting/ranging_eval.h"
#include "fitting/robot_config_json.h"
#include "fitting/servo_resolution_fit.h"
#include "fitting/step_response.h"
#include "fitting/stereo_sanity.h"
#include "fitting/truth_compare.h"
#include "models/head_kinematics.h"
#include "protocols/dataset.h"
#include "protocols/dataset_tables.h"
#include "protocols/fixation.h"
#include "protocols/placement_views.h"
#include "protocols/protocol.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

std::vector<calib::CornerObservation> ReadObs(const std::string& dataset) {
  const std::string p = dataset + "/observations.csv";
  if (dataset.empty() || !fs::exists(p)) return {};
  return calib::ReadObservationsCsv(p);
}

void SplitEyes(const std::vector<calib::View>& views, std::vector<calib::View>* l, std::vector<calib::View>* r) {
  for (const auto& v : views) (v.eye == models::kLeftEye ? l : r)->push_back(v);
}

// The report's name of a calibration view (frame numbers as offset in the stereo fit below).
std::string ViewName(int frame, int /*eye*/) {
  if (frame >= 2000000) return "intrinsics frame " + std::to_string(frame - 2000000);
  if (frame >= 1000000) return "stereo frame " + std::to_string(frame - 1000000);
  return "intrinsics frame " + std::to_string(frame);
}

// Where each of the dataset's targets is fixated, in the target's own frame: the centre of its
// extent (protocols/fixation.cc BoardLocator aims at a board's centre; a disc's is its origin),
// by target name (protocols::TargetsOfDataset). A board's placement pose is its corner grid's
// origin, 0.15 m from its centre for a 0.22 m board: the true distance is to the point the eyes
// fixated.
std::map<std::string, Eigen::Vector3d> AimPointsOfDataset(const std::string& dataset) {
  std::map<std::string, Eigen::Vector3d> out;
  for (const auto& [name, def] : protocols::TargetsOfDataset(dataset)) {
    const Eigen::Vector4d e = def.Extent();
    out[name] = Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0);
  }
  return out;
}

std::vector<fitting::Fixation> ReadFixations(const std::string& dataset,
                                             const models::RobotConfig& config,
                                             const std::optional<models::HeadModel>& truth,
                                             const models::HeadModel& fitted,
                                             std::vector<std::string>* excluded) {
  std::vector<fitting::Fixation> out;
  const std::vector<protocols::FixationRow> rows = protocols::ReadFixationsCsv(dataset);
  const auto placements = protocols::ReadPlacementsCsv(dataset);
  const std::map<std::string, Eigen::Vector3d> aim = AimPointsOfDataset(dataset);
  const double cx = (config.image_width - 1) / 2.0, cy = (config.image_height - 1) / 2.0;
  for (size_t r = 0; r < rows.size(); ++r) {
    const protocols::FixationRow& row = rows[r];
    // Every fixation is a row of the ranging table with its status; only "ok" is ranged. Older
    // datasets have no status column: it follows from the outcome.
    fitting::Fixation f;
    f.index = int(r);
    if (row.status) {
      f.status = *row.status;
      f.reason = row.reason;
    } else if (row.outcome != "converged") {
      f.status = row.outcome == "target-lost" ? calib::TrialStatus::kLostTarget : calib::TrialStatus::kNotSettled;
      f.reason = "outcome " + row.outcome;
    }
    const bool found[2] = {row.found[0] && row.offset_px[0].has_value(), row.found[1] && row.offset_px[1].has_value()};
    if (f.status == calib::TrialStatus::kOk && !(found[0] && found[1])) {
      f.status = calib::TrialStatus::kLostTarget;
      f.reason = std::string("target not found in the ") + (found[0] ? "right" : "left") + " image";
    }
    f.pwm_us = row.pwm_us;
    f.approach = row.approach;
    for (int e = 0; e < 2; ++e) f.radius_px[e] = row.radius_px[e];
    f.target_radius_m = row.target_radius_m;
    for (int e = 0; e < 2; ++e)
      if (found[e]) f.target_px[e] = Eigen::Vector2d(cx, cy) + *row.offset_px[e];
    // True distance: from the fixated point of the placed target (base frame; AimPointsOfDataset)
    // to the midpoint of the eye centres (the truth's on the virtual Owl, else the fitted
    // head's); else the logged distance.
    const models::HeadModel& ref = truth ? *truth : fitted;
    const double neck = ref.ServoAngle(models::kNeck, f.pwm_us[models::kNeck]);
    const Eigen::Vector3d mid = models::HeadFromBase(neck).Inverse() *
                                (0.5 * (ref.geometry.centre_in_head[0] + ref.geometry.centre_in_head[1]));
    f.true_distance_m = row.distance_m.value_or(NAN);
    for (const auto& p : placements)
      if (p.placement_index == row.placement_index) {
        const auto a = aim.find(p.target);
        const Eigen::Vector3d point = a == aim.end() ? Eigen::Vector3d::Zero() : a->second;
        f.true_distance_m = (p.base_from_target * point - mid).norm();
      }
    if (!std::isfinite(f.true_distance_m) && f.status == calib::TrialStatus::kOk) {
      f.status = calib::TrialStatus::kSkipped;
      f.reason = "no true distance (no placement or distance_m)";
    }
    if (f.status != calib::TrialStatus::kOk)
      excluded->push_back("vergence fixation " + std::to_string(r) + " (fixations.csv line " +
                          std::to_string(row.line) + ") not ranged: " + calib::TrialStatusName(f.status) + ": " +
                          f.reason);
    out.push_back(f);
  }
  return out;
}

// The PWM step and dead band of every servo the limits step swept (resolution.csv), fitted by
// fitting/servo_resolution_fit.h, written to the result as servo.<S>.pwm_step_us and
// servo.<S>.dead_band_us: the step is exact when determined; the dead band is known only to the
// range of values that replay the sweep identically (within a step when the step exceeds 1 us),
// so its value is the middle of that range and its sigma that of a uniform spread over it.
std::vector<fitting::ServoResolutionResult> FitResolution(const std::string& dataset,
                                                          fitting::CalibrationResult* result) {
  std::map<std::string, std::vector<fitting::ResolutionSample>> samples;
  for (const protocols::ResolutionRow& row : protocols::ReadResolutionCsv(dataset)) {
    if (row.status == calib::TrialStatus::kSkipped) {
      result->warnings.push_back("servo resolution of " + row.servo + " not measured: " + row.reason);
      continue;
    }
    samples[row.servo].push_back({row.command_us, row.position_px.value_or(NAN)});
  }
  std::vector<fitting::ServoResolutionResult> out;
  for (const auto& [name, s] : samples) {
    const int servo = protocols::ServoIndexFromName(name);
    if (servo < 0) throw std::runtime_error(dataset + "/resolution.csv: '" + name + "' is not a servo");
    fitting::ServoResolutionResult r;
    r.servo = servo;
    r.fit = fitting::FitServoResolution(s);
    const std::string p = "servo." + name + ".";
    if (!r.fit.ok || !r.fit.determined) {
      result->warnings.push_back("servo resolution of " + name + " not determined: " + r.fit.message);
    } else {
      const fitting::ResolutionFit& f = r.fit;
      const double db_mid = 0.5 * (f.dead_band_min_us + f.dead_band_max_us);
      const double db_sigma = (f.dead_band_max_us - f.dead_band_min_us) / std::sqrt(12.0);
      result->Set({p + "pwm_step_us",
                   double(f.resolution.step_us),
                   0,
                   "us",
                   {},
                   true,
                   "fine sweep at the centre (resolution.csv), RMS " + reports::Fmt(f.rms_px, 3) + " px, next model " +
                       f.runner_up + " " + reports::Fmt(f.runner_up_rms_px, 3) + " px"});
      result->Set({p + "dead_band_us",
                   db_mid,
                   db_sigma,
                   "us",
                   {},
                   true,
                   f.dead_band_determined
                       ? "fine sweep at the centre (resolution.csv)"
                       : "dead bands " + std::to_string(f.dead_band_min_us) + "-" + std::to_string(f.dead_band_max_us) +
                             " us replay the sweep identically (uniform over them)"});
    }
    out.push_back(r);
  }
  return out;
}

// The pulse each servo applied at a fixation's settled command, and its uncertainty, from the
// measured resolution: the generator produces Stepped(command). The fixation seats its command on
// the 5 us grid with one move of 10 us (protocols/fixation.h), so a command on that grid, with a
// step that divides 5 us and a dead band of at most 10 us, is the applied pulse exactly. Otherwise
// the servo may have ignored the last change: uniform within the dead band (sigma (d - 1) / sqrt(3)).
// Only determined fits are used; a servo without one is ranged at its command, as before.
void ApplyResolution(const std::vector<fitting::ServoResolutionResult>& resolution, fitting::Fixation* f) {
  if (resolution.empty()) return;
  models::PwmVector applied = f->pwm_us;
  for (const fitting::ServoResolutionResult& r : resolution) {
    if (!r.fit.ok || !r.fit.determined || r.servo < 0 || r.servo >= models::kNumServos) continue;
    const models::ServoResolution& res = r.fit.resolution;
    const int cmd = f->pwm_us[r.servo];
    applied[r.servo] = res.Stepped(cmd);
    const bool seated = cmd % 5 == 0 && 5 % res.step_us == 0 && r.fit.dead_band_max_us <= 10;
    f->applied_sigma_us[r.servo] = seated ? 0.0 : (std::max(1, r.fit.dead_band_max_us) - 1) / std::sqrt(3.0);
  }
  f->applied_us = applied;
}

// The measured ends of a limits dataset (pipeline/bring_up.h LimitMeasurements).
std::vector<fitting::LimitMeasurement> ReadLimits(const std::string& dataset,
                                                  std::vector<std::string>* failed,
                                                  int* num_rows) {
  return LimitMeasurements(protocols::ReadLimitsCsv(dataset), failed, num_rows);
}

// Median latency in frames from latency.csv; nullopt without data.
std::optional<double> MedianLatencyMs(const std::string& dataset) {
  std::vector<double> v;
  for (const protocols::LatencyRow& row : protocols::ReadLatencyCsv(dataset))
    if (row.latency_ms) v.push_back(*row.latency_ms);
  if (v.empty()) return std::nullopt;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

std::optional<int> LatencyFrames(const std::string& dataset, double fps) {
  const std::optional<double> ms = MedianLatencyMs(dataset);
  if (!ms) return std::nullopt;
  return std::max(1, int(std::lround(*ms * fps / 1000.0)));
}

// Latency against the truth, alignment against its tolerance, field of view against the
// datasheet: results.json diagnostics.reference_checks (fitting/reference_checks.h).
void AddReferenceChecks(const std::string& latency_dir,
                        const std::string& alignment_dir,
                        const CalibratePipelineOptions& o,
                        fitting::CalibrationRun* d) {
  nlohmann::json checks = nlohmann::json::object();
  if (!latency_dir.empty()) {
    std::vector<fitting::LatencyTrial> trials;
    for (const protocols::LatencyRow& row : protocols::ReadLatencyCsv(latency_dir)) {
      fitting::LatencyTrial t;
      t.step_index = row.step_index;
      t.trial = row.trial;
      t.servo = protocols::ServoIndexFromName(row.servo);
      if (t.servo < 0)
        throw std::runtime_error(latency_dir + "/latency.csv:" + std::to_string(row.line) + ": column servo = '" +
                                 row.servo + "' is not Rx, Ry, Lx, Ly or Neck");
      t.amplitude_us = row.amplitude_us;
      t.latency_ms = row.latency_ms;
      t.command_ns = row.command_ns;
      t.from_us = row.from_us;
      t.to_us = row.to_us;
      t.threshold_px = row.threshold_px;
      trials.push_back(t);
    }
    checks["latency"] = fitting::ToJson(fitting::CheckLatency(trials, o.latency_truth));
  }
  if (!alignment_dir.empty()) {
    std::vector<fitting::AlignmentFrame> frames;
    for (const protocols::AlignmentRow& row : protocols::ReadAlignmentCsv(alignment_dir))
      frames.push_back({row.method, row.roll_deg, row.vertical_offset_px, row.horizontal_offset_px});
    // The offset in us of tilt: the fitted focal length and tilt scale when there are, else nominal.
    double focal = protocols::NominalFocalPx(o.config);
    if (d->result.cameras[0]) focal = d->result.cameras[0]->params[1];
    double deg_per_us = o.config.servos[models::kLy].nominal_deg_per_us;
    if (const fitting::Parameter* p = d->result.Find("servo.Ly.deg_per_us"); p && p->determined) deg_per_us = p->value;
    checks["alignment"] = fitting::ToJson(fitting::CheckAlignment(frames, o.config.image_width, focal, deg_per_us));
  }
  if (d->result.cameras[0] || d->result.cameras[1]) {
    std::optional<std::array<models::CameraIntrinsics, 2>> truth;
    if (o.truth) truth = std::array<models::CameraIntrinsics, 2>{o.truth->intrinsics[0], o.truth->intrinsics[1]};
    checks["field_of_view"] = fitting::ToJson(fitting::CheckFieldOfView(d->result, truth));
  }
  if (!checks.empty()) d->result.diagnostics["reference_checks"] = checks;
}

void MergeHead(const fitting::HeadFit& h, fitting::CalibrationResult* r) {
  for (const auto& p : h.result.parameters) r->Set(p);
  for (const auto& s : h.result.summaries) r->summaries.push_back(s);
  for (const auto& w : h.result.warnings) r->warnings.push_back(w);
  r->head = h.head;
  if (h.result.diagnostics.contains("head")) r->diagnostics["head"] = h.result.diagnostics["head"];
  for (auto it = h.result.inputs.begin(); it != h.result.inputs.end(); ++it) r->inputs[it.key()] = it.value();
  if (h.covariance.rows() == int(h.param_names.size()) && !h.param_names.empty()) {
    nlohmann::json m = nlohmann::json::array();
    for (int i = 0; i < h.covariance.rows(); ++i) {
      std::vector<double> row(h.covariance.cols());
      for (int j = 0; j < h.covariance.cols(); ++j)
        row[j] = std::isfinite(h.covariance(i, j)) ? h.covariance(i, j) : 0.0;
      m.push_back(row);
    }
    r->diagnostics["covariance"] = {{"names", h.param_names}, {"matrix", m}, {"source", "head fit"}};
  }
}

// Sigma of the stereo fit's focal scale: g = mean of log fx, log fy over both eyes, through the
// joint covariance of the two eyes' intrinsics (their errors are correlated: one board in both
// views). 0 when the fit has none.
double FocalScaleSigma(const fitting::StereoFit& f) {
  const int n = int(f.cameras[0].params.size());
  if (n < 2 || int(f.cameras[1].params.size()) != n || f.covariance.rows() < 2 * n) return 0.0;
  std::vector<std::pair<int, double>> a;  // covariance row, d g / d value
  for (int e = 0; e < 2; ++e)
    for (int k = 0; k < 2; ++k)
      if (f.cameras[e].params[k] > 0) a.emplace_back(e * n + k, 0.25 / f.cameras[e].params[k]);
  double var = 0;
  for (const auto& [i, ai] : a)
    for (const auto& [j, aj] : a) var += ai * f.covariance(i, j) * aj;
  return std::isfinite(var) && var > 0 ? std::sqrt(var) : 0.0;
}

// Covariance of one eye's intrinsics (fx fy cx cy dist..., the head's camera block) from the
// stereo fit, times widen^2; nullopt when the fit has none. A parameter the stereo fit did not
// determine (zero row) gets a variance of 1e8 (sigma 1e4 px or 1e4 in a coefficient): no prior.
std::optional<Eigen::MatrixXd> IntrinsicsPriorFromStereo(const fitting::StereoFit& f, int eye, double widen) {
  const int n = int(f.cameras[eye].params.size());
  if (f.covariance.rows() < 2 * n) return std::nullopt;
  Eigen::MatrixXd c = f.covariance.block(eye * n, eye * n, n, n) * (widen * widen);
  bool any = false;
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(c(i, i)) && c(i, i) > 0) {
      any = true;
      continue;
    }
    c.row(i).setZero();
    c.col(i).setZero();
    c(i, i) = 1e8;
  }
  if (!any || !c.allFinite() || Eigen::LLT<Eigen::MatrixXd>(c).info() != Eigen::Success) return std::nullopt;
  return c;
}

}  // namespace

std::vector<fitting::StepTrace> ReadStepTraces(const std::string& dataset) {
  std::vector<fitting::StepTrace> out;
  using Key = std::tuple<int, double, double, int>;
  std::map<Key, fitting::StepTrace> by;
  std::vector<Key> order;
  auto add = [&](const Key& key) {
    if (by.count(key)) return;
    order.push_back(key);
    fitting::StepTrace s;
    s.gain = std::get<1>(key);
    s.amplitude_deg = std::get<2>(key);
    s.trial = std::get<3>(key);
    by[key] = s;
  };
  for (const protocols::StepResponseRow& row : protocols::ReadStepResponseCsv(dataset)) {
    const Key key{row.step_index, row.gain, row.amplitude_deg, row.trial};
    add(key);
    if (!row.found || !row.offset_px) continue;
    by[key].t_s.push_back(row.t_s);
    by[key].y.push_back(*row.offset_px);  // converted below
  }
  // The trials' statuses (step_trials.csv); trials without frames (skipped) are rows too.
  std::map<Key, std::pair<calib::TrialStatus, std::string>> status;
  for (const protocols::StepTrialRow& row : protocols::ReadStepTrialsCsv(dataset)) {
    const Key key{row.step_index, row.gain, row.amplitude_deg, row.trial};
    auto st = row.status;
    if (!st)
      st = row.outcome == "converged"     ? calib::TrialStatus::kOk
           : row.outcome == "no-fixation" ? calib::TrialStatus::kSkipped
           : row.outcome == "target-lost" ? calib::TrialStatus::kLostTarget
                                          : calib::TrialStatus::kNotSettled;
    std::string reason = row.reason;
    if (reason.empty() && *st != calib::TrialStatus::kOk) reason = "outcome " + row.outcome + ": " + row.message;
    status[key] = {*st, reason};
    add(key);
  }
  for (const auto& key : order) {
    fitting::StepTrace s = by[key];
    s.eye_axis = "step-response";
    if (auto it = status.find(key); it != status.end()) {
      s.status = it->second.first;
      s.reason = it->second.second;
    }
    if (s.y.size() < 3 || std::abs(s.y.front()) < 1e-6) {
      // Not a usable step response: a row with its status, no metrics.
      if (s.status == calib::TrialStatus::kOk) {
        s.status = calib::TrialStatus::kLostTarget;
        s.reason = s.y.size() < 3 ? "the target was seen in " + std::to_string(s.y.size()) + " frames of the trial"
                                  : std::string("no step: the target was centred in the first frame");
      }
      s.t_s.clear();
      s.y.clear();
      out.push_back(s);
      continue;
    }
    const double o0 = s.y.front();
    s.residual_px = std::abs(s.y.back());
    for (double& y : s.y) y = 1.0 - y / o0;  // fraction of the step done
    fitting::StepInfoOptions o;
    o.y_init = 0.0;
    o.y_final = 1.0;
    try {
      s.info = fitting::ComputeStepInfo(s.t_s, s.y, o);
    } catch (const std::exception& e) {
      // e.g. non-increasing times (dropped frames logged twice): a row, not a silent drop.
      s.status = calib::TrialStatus::kFailed;
      s.reason = std::string("no step metrics: ") + e.what();
      s.t_s.clear();
      s.y.clear();
    }
    out.push_back(s);
  }
  return out;
}

// Why each value: docs/uncertainty.md (the noise model, with the figures each was chosen on).
fitting::StereoFitOptions CalibratePipelineOptions::CalibrateStereoFitOptions() {
  fitting::StereoFitOptions so;
  so.fit_board_warp = true;  // a real course board bows by about 1 mm
  // The rational lens as (1 + k1 r^2) / (1 + k4 r^2): its six radial terms trade against each other.
  so.intrinsics.rational_fix_radial = {2, 3, 5, 6};
  return so;
}

fitting::HeadFitOptions CalibratePipelineOptions::CalibrateHeadFitOptions() {
  fitting::HeadFitOptions ho;
  ho.fit_intrinsics = true;         // refined on the sweep: held, their errors bias the pan zeros
  ho.fit_board_warp = true;         // a bow fitted as flat moves focal lengths, servo scales and IPD together
  ho.estimate_corner_sigma = true;  // whiten by the noise the residuals show, per eye
  ho.measured_sigma_factor = 1.4;   // the detector bias neighbouring views share
  ho.hysteresis_sigma_floor_us = 0;
  ho.covariance_clusters = "cell:100";  // sandwich covariance over placement x 100 us cells
  ho.robust_sigma_factor = 1.0;
  ho.intrinsics_floor_carry = "servo_maps";  // a focal-length error scales every angle the maps give
  ho.pan_zero_sigma_factor = 1.25;           // the head-yaw gauge's eye-depth difference
  ho.rational_fix_radial = {2, 3, 5, 6};     // the stereo fit's rational lens form
  return ho;
}

bool CalibratePipelineOptions::Check(std::string* why) const {
  if (!(fps > 0 && fps <= 1000)) {
    *why = "fps must be in (0, 1000]";
    return false;
  }
  if (default_delay_frames < 1) {
    *why = "default_delay_frames must be >= 1";
    return false;
  }
  if (!(fused_floor_scale >= 0 && fused_floor_scale <= 10)) {
    *why = "fused_floor_scale must be in [0, 10]";
    return false;
  }
  if (!(tag_sigma_factor >= 1 && tag_sigma_factor < 100)) {
    *why = "tag_sigma_factor must be in [1, 100)";
    return false;
  }
  if (!(theory_min_m > 0 && theory_max_m >= theory_min_m && theory_step_m > 0)) {
    *why = "theory distances need 0 < min <= max and step > 0";
    return false;
  }
  if (!stereo.Check(why)) return false;
  if (!lens_choice.Check(why)) return false;
  return head.Check(why);
}

nlohmann::json CalibratePipelineOptions::ToJson() const {
  const fitting::IntrinsicsFitOptions& in = stereo.intrinsics;
  nlohmann::json h = {
      {"corner_sigma_px", head.corner_sigma_px},
      {"estimate_corner_sigma", head.estimate_corner_sigma},
      {"measured_sigma_factor", head.measured_sigma_factor},
      {"min_corner_sigma_px", head.min_corner_sigma_px},
      {"hysteresis_sigma_floor_us", head.hysteresis_sigma_floor_us},
      {"covariance_clusters", head.covariance_clusters},
      {"robust_sigma_factor", head.robust_sigma_factor},
      {"intrinsics_floor_carry", head.intrinsics_floor_carry},
      {"pan_zero_sigma_factor", head.pan_zero_sigma_factor},
      {"view_outlier_factor", head.view_outlier_factor},
      {"noise_class_of_board", head.noise_class_of_board},
      {"tag_size_of_board", head.tag_size_of_board},
      {"fit_intrinsics", head.fit_intrinsics},
      {"fit_board_warp", head.fit_board_warp},
      {"intrinsics_prior",
       head.intrinsics_prior_covariance[0].has_value() || head.intrinsics_prior_covariance[1].has_value()},
      {"intrinsics_prior_from_stereo", head_prior_from_stereo},
      {"fit_nonlinear", head.fit_nonlinear},
      {"fit_hysteresis", head.fit_hysteresis},
      {"huber_sigma", head.huber_sigma},
      {"outlier_threshold_sigma", head.outlier_threshold_sigma},
      {"min_corners_per_view", head.min_corners_per_view},
      {"max_iterations", head.max_iterations},
      {"rank_tolerance", head.rank_tolerance},
      {"num_threads", head.num_threads}};
  nlohmann::json i = {{"model", in.model == models::DistortionModel::kOpenCv8 ? "opencv8" : "opencv5"},
                      {"fix_aspect_ratio", in.fix_aspect_ratio},
                      {"fix_principal_point", in.fix_principal_point},
                      {"fix_k3", in.fix_k3},
                      {"fix_tangential", in.fix_tangential},
                      {"corner_sigma_px", in.corner_sigma_px},
                      {"loss",
                       in.loss == fitting::RobustLoss::kHuber    ? "huber"
                       : in.loss == fitting::RobustLoss::kCauchy ? "cauchy"
                                                                 : "none"},
                      {"loss_scale_sigma", in.loss_scale_sigma},
                      {"outlier_threshold_sigma", in.outlier_threshold_sigma},
                      {"min_corners_per_view", in.min_corners_per_view},
                      {"max_iterations", in.max_iterations},
                      {"max_sigma_px", in.max_sigma_px},
                      {"max_sigma_distortion", in.max_sigma_distortion},
                      {"rank_tolerance", in.rank_tolerance}};
  nlohmann::json s = {{"intrinsics", i},
                      {"width", stereo.width},
                      {"height", stereo.height},
                      {"fix_intrinsics", stereo.fix_intrinsics},
                      {"fit_board_warp", stereo.fit_board_warp},
                      {"length_unit", stereo.length_unit},
                      {"rectify_alpha", stereo.rectify_alpha},
                      {"max_iterations", stereo.max_iterations}};
  const nlohmann::json lens = {{"enabled", lens_choice.enabled},
                               {"folds", lens_choice.folds},
                               {"min_frames", lens_choice.min_frames},
                               {"min_relative_gain", lens_choice.min_relative_gain}};
  return {{"robot", fitting::RobotConfigToJson(config)},
          {"bring_up", bring_up.has_value()},
          {"lens_choice", lens},
          {"truth", truth.has_value()},
          {"fps", fps},
          {"truth_slew_deg_per_s", truth_slew_deg_per_s},
          {"truth_latency_s", truth_latency_s},
          {"default_delay_frames", default_delay_frames},
          {"fuse_tags", fuse_tags},
          {"tag_sigma_factor", tag_sigma_factor},
          {"fused_floor_scale", fused_floor_scale},
          {"fused_pinhole_floor", fused_pinhole_floor},
          {"fused_pan_zero_floor", fused_pan_zero_floor},
          {"stereo", s},
          {"head", h},
          {"theory_distances_m", {theory_min_m, theory_max_m, theory_step_m}}};
}

bool SetLensModel(const std::string& value, CalibratePipelineOptions* o, std::string* why) {
  o->lens_choice.enabled = value == "auto";
  if (value == "opencv5" || value == "auto")
    o->stereo.intrinsics.model = models::DistortionModel::kOpenCv5;
  else if (value == "opencv8")
    o->stereo.intrinsics.model = models::DistortionModel::kOpenCv8;
  else {
    if (why) *why = "--lens-model = '" + value + "': use auto, opencv5 or opencv8";
    return false;
  }
  return true;
}

fitting::CalibrationRun FitCalibration(const std::map<std::string, std::string>& datasets,
                                       const CalibratePipelineOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("calibrate pipeline options: " + why);
  auto progress = [&](const std::string& m) {
    if (o.progress) o.progress(m);
  };
  auto dataset = [&](const char* name) -> std::string {
    const auto it = datasets.find(name);
    return it == datasets.end() ? std::string() : it->second;
  };
  using reports::Fmt;
  const models::RobotConfig& config = o.config;
  fitting::CalibrationRun d;
  d.config = config;
  static const std::set<std::string> kKnown = {
      "intrinsics", "stereo", "servo_sweep", "vergence", "latency", "step_response", "limits", "alignment", "saccade"};
  for (const auto& [name, dir] : datasets) {
    if (kKnown.count(name)) continue;
    // Skipped, so the fit lacks what it holds (a renamed intrinsics dataset widens every sigma):
    // a warning, never only a progress line.
    std::string known;
    for (const auto& k : kKnown) {
      if (!known.empty()) known += ", ";
      known += k;
    }
    const std::string w = "dataset " + dir + " skipped: its manifest names protocol '" + name +
                          "', which no calibration step reads (known: " + known + ")";
    d.result.warnings.push_back(w);
    if (o.warning)
      o.warning(w);
    else
      progress(w);
  }

  // 0) What the bring-up learned and the protocols after it used.
  if (o.bring_up) {
    d.result.diagnostics["bring_up"] = o.bring_up->ToJson();
    for (const auto& f : o.bring_up->findings) {
      d.result.warnings.push_back("robot file: " + f);
      progress("bring-up: " + f);
    }
  }

  // 1) Intrinsics + stereo from the intrinsics and stereo datasets.
  std::optional<fitting::StereoFit> stereo;
  {
    // The intrinsics capture moves the eyes, so its left/right frames do not share one
    // right_from_left: keep them unpaired (they constrain each eye's intrinsics only). Only the
    // stereo capture, taken at one fixed eye pose, pairs left with right.
    std::vector<calib::CornerObservation> obs = ReadObs(dataset("intrinsics"));
    for (auto& c : obs)
      if (c.eye == models::kRightEye) c.frame_index += 2000000;
    for (auto c : ReadObs(dataset("stereo"))) {
      c.frame_index += 1000000;  // keep frames of the two datasets apart
      obs.push_back(c);
    }
    const std::vector<calib::View> views = calib::GroupIntoViews(obs);
    std::vector<calib::View> l, r;
    SplitEyes(views, &l, &r);
    progress("stereo fit: " + std::to_string(l.size()) + " left and " + std::to_string(r.size()) + " right views");
    if (!l.empty() && !r.empty()) {
      std::optional<fitting::LensModelChoice> lens;
      if (o.lens_choice.enabled) {
        // The lens model by cross-validation; the chosen model's fit on all views is the fit.
        lens = fitting::ChooseStereoLensModel(l, r, o.stereo, o.lens_choice);
        progress("  lens model: " + lens->reason + " [" + Fmt(lens->time_s, 3) + " s]");
        const fitting::LensModelScore* s = lens->Score(lens->chosen);
        if (s) stereo = s->full;
      }
      if (!stereo) {
        fitting::StereoFitOptions so = o.stereo;
        so.intrinsics = fitting::WithModel(so.intrinsics, lens ? lens->chosen : so.intrinsics.model);
        stereo = fitting::FitStereo(l, r, so);
      }
      if (lens) fitting::AppendLensModelChoiceToResult(*lens, &d.result);
      if (stereo->ok) {
        fitting::AppendStereoToResult(*stereo, &d.result);
        // Physical sanity against this robot (fitting/stereo_sanity.h): a mirrored or swapped
        // stream setting shows as T_x > 0, and is named with the robot-file field to change.
        fitting::RigExpectation rig = fitting::RigExpectation::Owl();
        rig.ipd_m = config.ipd_m;
        const fitting::StereoSanity sanity =
            fitting::CheckStereoSanity(stereo->cameras, stereo->right_from_left, 1.0, rig);
        fitting::AppendSanityToResult(sanity, rig, &d.result);
        for (const auto& f : sanity.findings)
          progress("  sanity (" + std::string(f.unusable ? "unusable" : "poor") + "): " + f.message +
                   (f.check == "tx_sign" ? " [robot file: image.mirror / image.swap_eyes]" : ""));
        fitting::AddFitPoints(*stereo, views, ViewName, &d);
        progress("  RMS " + Fmt(stereo->rms_px[0], 3) + " / " + Fmt(stereo->rms_px[1], 3) + " px");
      } else {
        d.result.warnings.push_back("stereo fit failed: " + stereo->message);
        progress("  failed: " + stereo->message);
      }
    } else {
      d.result.warnings.push_back("no chessboard views: intrinsics and stereo not fitted");
    }
  }

  // 2) The head from the servo sweep.
  models::HeadModel initial = models::NominalHeadModel(config);
  for (int e = 0; e < 2; ++e)
    if (d.result.cameras[e]) initial.intrinsics[e] = *d.result.cameras[e];
  bool neck_moved = false;
  // The sweep's views, the head fit on all of them and the one without the tags (tag study).
  std::vector<calib::View> sweep_views;
  fitting::HeadFitOptions head_options = o.head;
  std::optional<fitting::HeadFit> with_tags, without_tags;
  if (!dataset("servo_sweep").empty()) {
    // One board per placement: the sweep places the same chessboard at five poses (the tag
    // sheets around it stay put: one board each).
    sweep_views = protocols::ReadViewsByPlacement(dataset("servo_sweep"));
    const auto& views = sweep_views;
    // Chessboard and tag corners in one fit, each kind whitened by its own measured noise.
    for (const auto& [board, cls] : NoiseClassesOfDataset(dataset("servo_sweep")))
      head_options.noise_class_of_board.emplace(board, cls);
    // ... and each tag corner compared with where the detector puts it under the lens's
    // distortion (fitting/tag_edge_corner.h).
    for (const auto& [board, size] : TagSizesOfDataset(dataset("servo_sweep")))
      head_options.tag_size_of_board.emplace(board, size);
    // ... whitened wider for the errors a static sheet repeats in every view (CalibratePipelineOptions).
    for (const auto& [board, size] : head_options.tag_size_of_board)
      if (const auto it = head_options.noise_class_of_board.find(board); it != head_options.noise_class_of_board.end())
        head_options.sigma_factor_of_class[it->second] = o.tag_sigma_factor;
    const size_t num_chessboard_views = WithoutTags(views, head_options.noise_class_of_board).size();
    progress("head fit: " + std::to_string(views.size()) + " views (" +
             std::to_string(views.size() - num_chessboard_views) + " of tag sheets)");
    for (const auto& v : views) neck_moved |= v.pwm_us[models::kNeck] != config.servos[models::kNeck].centre_us;
    // The stereo fit's intrinsics as a prior (CalibratePipelineOptions::head_prior_from_stereo):
    // the sweep's boards pin the focal lengths, the servo scales and the IPD only together; the
    // stereo views pin the focal lengths on their own (docs/uncertainty.md).
    fitting::HeadFitOptions& ho = head_options;
    bool prior_from_stereo = false;
    if (o.head_prior_from_stereo && ho.fit_intrinsics && stereo && stereo->ok && !ho.intrinsics_prior_covariance[0] &&
        !ho.intrinsics_prior_covariance[1]) {
      for (int e = 0; e < 2; ++e) {
        ho.intrinsics_prior_covariance[e] = IntrinsicsPriorFromStereo(*stereo, e, ho.measured_sigma_factor);
        prior_from_stereo |= ho.intrinsics_prior_covariance[e].has_value();
        // ... and its covariance (as fitted) the floor of the head fit's: the sweep's views
        // share the detector's bias with the stereo views (HeadFitOptions::intrinsics_covariance_floor).
        ho.intrinsics_covariance_floor[e] = IntrinsicsPriorFromStereo(*stereo, e, 1.0);
      }
      if (prior_from_stereo)
        progress("  intrinsics prior: the stereo fit's covariance x " + Fmt(ho.measured_sigma_factor, 3) + "^2");
    }
    // With tag views, the fit on the chessboard alone and the fit fusing the tags: two
    // independent single-threaded fits, run at once. The result is the chessboard's unless
    // fuse_tags (CalibratePipelineOptions); the tag study compares them.
    const bool has_tags = num_chessboard_views < views.size();
    std::vector<fitting::HeadFit> fits(has_tags ? 2 : 1);
    fitting::HeadFitOptions fused_options = ho;
    for (auto& floor : fused_options.intrinsics_covariance_floor) {
      if (!floor) continue;
      if (o.fused_floor_scale > 0)
        *floor *= o.fused_floor_scale * o.fused_floor_scale;
      else
        floor.reset();
    }
    // ... and the focal scale and the principal points no better known than the stereo fit knows
    // them (HeadFitOptions::focal_scale_sigma_floor, principal_point_covariance_floor): the static
    // tag sheets move them by more than their residuals show (CalibratePipelineOptions::
    // fused_pinhole_floor).
    if (o.fused_pinhole_floor && prior_from_stereo && stereo) {
      fused_options.focal_scale_sigma_floor = FocalScaleSigma(*stereo);
      for (int e = 0; e < 2; ++e)
        if (const auto f = IntrinsicsPriorFromStereo(*stereo, e, 1.0); f && f->rows() >= 4)
          fused_options.principal_point_covariance_floor[e] = Eigen::MatrixXd(f->block(2, 2, 2, 2));
    }
    auto fit = [&](int k) {
      fits[k] = k == 0 ? fitting::FitHead(WithoutTags(views, head_options.noise_class_of_board), config, initial, ho)
                       : fitting::FitHead(views, config, initial, fused_options);
    };
    if (has_tags && o.fused_pan_zero_floor) {
      // ... and its pan zero no better known than the chessboard's fit knows it (HeadFitOptions::
      // pan_zero_sigma_floor_deg): the fits run one after the other.
      fit(0);
      const nlohmann::json pz = fits[0]
                                    .result.diagnostics.value("head", nlohmann::json::object())
                                    .value("pan_zero", nlohmann::json::object());
      if (fits[0].ok && pz.contains("sigma_deg") && pz["sigma_deg"].is_number()) {
        const double floor_deg = pz["sigma_deg"].get<double>();
        // A sigma of ten degrees or more is no floor: the chessboard fit did not determine the pan
        // zero (a lens model whose coefficients the data cannot separate). The fused fit keeps
        // its own, and the run says so.
        if (std::isfinite(floor_deg) && floor_deg < 10) {
          fused_options.pan_zero_sigma_floor_deg = floor_deg;
        } else {
          d.result.warnings.push_back("pan zero: the chessboard-only head fit did not determine it (sigma " +
                                      Fmt(floor_deg, 3) +
                                      " deg), so it does not floor the fused fit's; the pans' absolute angles "
                                      "carry the fused fit's own sigma");
        }
      }
      fit(1);
    } else {
      // Two independent single-threaded fits, run at once.
      cv::parallel_for_(cv::Range(0, int(fits.size())), [&](const cv::Range& r) {
        for (int k = r.start; k < r.end; ++k) fit(k);
      });
    }
    if (has_tags) {
      without_tags = fits[0];
      with_tags = fits[1];
      progress("  with the tags: " + with_tags->message);
    }
    const fitting::HeadFit& h = has_tags && o.fuse_tags ? fits[1] : fits[0];
    if (h.ok) {
      MergeHead(h, &d.result);
      progress("  RMS " + Fmt(h.result.summaries.empty() ? NAN : h.result.summaries.back().rms_px, 3) + " px, IPD " +
               Fmt(d.result.Find("head.ipd_mm") ? d.result.Find("head.ipd_mm")->value : NAN, 5) + " mm");
    } else {
      d.result.warnings.push_back("head fit failed: " + h.message);
      progress("  failed: " + h.message);
    }
  }
  if (!d.result.head) {
    d.result.head = initial;
    d.result.warnings.push_back("no head fit: ranging uses the nominal head (configured centres, 0.113 deg/us)");
  }

  // 3) Truth (virtual Owl), in the fit's gauge.
  if (o.truth) {
    models::HeadModel canonical = fitting::CanonicalHead(
        *o.truth, config.servos[models::kNeck].centre_us, neck_moved, initial.geometry.centre_in_head[0]);
    // In the fit's direction convention (models/servo_map.h: the same angles with the direction
    // and the slope, quadratic and cubic terms negated), so a robot file whose direction is wrong
    // compares the map, not the sign convention.
    for (int s = 0; s < models::kNumServos; ++s)
      if (canonical.directions[s] != initial.directions[s]) {
        canonical.directions[s] = initial.directions[s];
        for (int k = 1; k <= 3; ++k) canonical.servo_params[s][k] = -canonical.servo_params[s][k];
      }
    d.truth = canonical;
    fitting::SetHeadTruth(canonical, &d.result);
    fitting::FillTruth(fitting::IntrinsicsTruthValues(*o.truth), &d.result);
    // The stereo truth at the stereo capture's command and approach (backlash side).
    models::PwmVector stereo_pwm = config.Centre();
    std::array<int, models::kNumServos> stereo_approach{};
    const auto obs = ReadObs(dataset("stereo"));
    if (!obs.empty()) {
      stereo_pwm = obs.front().pwm_us;
      for (int s = 0; s < models::kNumServos; ++s) stereo_approach[s] = obs.front().approach[s];
    }
    fitting::FillTruth(fitting::StereoTruthValues(*o.truth, stereo_pwm, stereo_approach), &d.result);
    // A lens fitted with another model than the truth's: by projection, not by coefficient.
    std::array<const models::CameraIntrinsics*, 2> fitted{};
    for (int e = 0; e < 2; ++e)
      fitted[e] =
          d.result.cameras[e] ? &*d.result.cameras[e] : (d.result.head ? &d.result.head->intrinsics[e] : nullptr);
    fitting::CompareLensByProjection(*o.truth, fitted, {"", "head."}, &d.result);
  }

  if (with_tags && with_tags->ok) {
    d.result.diagnostics["tags"] = TagStudy(sweep_views,
                                            head_options.noise_class_of_board,
                                            *with_tags,
                                            without_tags,
                                            config,
                                            d.truth ? &*d.truth : nullptr);
    d.result.diagnostics["tags"]["head_result"] = o.fuse_tags ? "fused (chessboard and tags)" : "chessboard only";
    if (o.fused_pinhole_floor || o.fused_pan_zero_floor)
      d.result.diagnostics["tags"]["floors"] =
          std::string("With the tags ") +
          (o.fused_pinhole_floor
               ? "the focal scale and the principal points stay as certain as the stereo fit makes them"
               : "") +
          (o.fused_pinhole_floor && o.fused_pan_zero_floor ? " and " : "") +
          (o.fused_pan_zero_floor ? "the pan zero as certain as the chessboard's fit makes it, so the pans' sigma at "
                                    "their ends, which the pan zero sets, does not shrink"
                                  : "") +
          " (the static sheets move them more than their residuals show; docs/conventions.md)";
    if (d.truth) {
      // Both head fits' parameters against the truth (the calibration's head is one of them), so
      // the Monte-Carlo bench scores the fused fit's sigmas as its own groups
      // (bench/robot_prior_mc_bench.cc).
      nlohmann::json fits = nlohmann::json::object();
      for (const auto& [key, fit] : {std::pair<const char*, const fitting::HeadFit*>{"fused", &*with_tags},
                                     {"chessboard", without_tags ? &*without_tags : nullptr}}) {
        if (!fit || !fit->ok) continue;
        fitting::CalibrationResult r;
        r.parameters = fit->result.parameters;
        fitting::SetHeadTruth(*d.truth, &r);
        fits[key] = fitting::ToJson(r)["parameters"];
      }
      d.result.diagnostics["tags"]["parameters"] = fits;
    }
    if (!o.fuse_tags) {
      // With the truth, this run's fused errors at the servo ends in its own sigmas; else what
      // was measured on the default virtual Owl.
      double z_lo = INFINITY, z_hi = 0;
      std::string worst;
      for (const auto& e : d.result.diagnostics["tags"].value("servo_ends", nlohmann::json::array())) {
        if (!e.contains("error_with_tags_deg") || !e["error_with_tags_deg"].is_number() ||
            !(e.value("sigma_with_tags_deg", 0.0) > 0))
          continue;
        const double z = std::abs(e["error_with_tags_deg"].get<double>()) / e["sigma_with_tags_deg"].get<double>();
        z_lo = std::min(z_lo, z);
        if (z > z_hi) z_hi = z, worst = e.value("servo", std::string()) + " " + e.value("end", std::string());
      }
      // Only what this run measured: a figure from a bench run elsewhere does not belong here.
      d.result.diagnostics["tags"]["note"] =
          "the calibration's head is the chessboard's (fuse_tags off); the with-tags sigmas are a diagnostic" +
          (z_hi > 0
               ? std::string("; in this run (the virtual Owl's truth) the fused fit's errors at the servo ends are ") +
                     Fmt(z_lo, 2) + "-" + Fmt(z_hi, 2) + " of its own sigmas (worst: " + worst + ")"
               : std::string());
    }
  }

  // 4) Evaluations. The servos' PWM step and dead band first: ranging, the settling model and the
  // saccade controller use them.
  if (!dataset("limits").empty()) {
    d.resolution = FitResolution(dataset("limits"), &d.result);
    for (const auto& r : d.resolution)
      progress("servo resolution " + std::string(models::kServoNames[r.servo]) + ": " +
               (r.fit.ok ? fitting::DescribeResolution(r.fit) : r.fit.message) +
               (r.fit.ok && !r.fit.determined ? " (not determined)" : ""));
  }
  if (!dataset("vergence").empty()) {
    std::vector<std::string> excluded;
    auto fixations = ReadFixations(dataset("vergence"), config, o.truth, *d.result.head, &excluded);
    for (auto& f : fixations) ApplyResolution(d.resolution, &f);
    for (const auto& x : excluded) d.result.warnings.push_back(x);
    const fitting::NamedCovariance cov = fitting::CovarianceFromResult(d.result, fitting::RangingParameterNames());
    std::vector<double> theory;
    for (double x = o.theory_min_m; x <= o.theory_max_m + 1e-4; x += o.theory_step_m) theory.push_back(x);
    d.ranging = fitting::EvaluateRanging(*d.result.head, cov, config, fixations, {}, theory);
    // No error figure without a ranged fixation (an RMS of nothing is not 0 %).
    const int tried = int(d.ranging->rows.size());
    if (tried == 0)
      progress("ranging: no fixation recorded (the vergence dataset has none: see the warnings)");
    else if (d.ranging->num_ok == 0)
      progress("ranging: 0 of " + std::to_string(tried) + " fixations ranged (the reasons are in the ranging table)");
    else
      progress("ranging: " + std::to_string(d.ranging->num_ok) + " of " + std::to_string(tried) +
               " fixations, RMS error " + Fmt(100 * d.ranging->rms_rel_error, 3) + " %, " +
               Fmt(100 * d.ranging->fraction_within_2sigma, 3) + " % within 2 sigma (course method " +
               Fmt(100 * d.ranging->nominal_rms_rel_error, 3) + " %)");
  }
  int delay = o.default_delay_frames;
  if (!dataset("latency").empty())
    if (auto lf = LatencyFrames(dataset("latency"), o.fps)) delay = *lf;
  d.gains = fitting::MakeGainStudy(delay, o.fps);
  if (!dataset("step_response").empty()) {
    d.steps = ReadStepTraces(dataset("step_response"));
    for (const auto& st : d.steps)
      if (st.status != calib::TrialStatus::kOk)
        d.result.warnings.push_back("step trial (gain " + Fmt(st.gain, 3) + ", " + Fmt(st.amplitude_deg, 3) +
                                    " deg, trial " + std::to_string(st.trial) + ") " +
                                    calib::TrialStatusName(st.status) + ": " + st.reason);
    progress("step responses: " + std::to_string(d.steps.size()) + " trials; delay " + std::to_string(delay) +
             " frames, K_crit " + Fmt(d.gains->critical_gain, 3));
    const std::optional<double> latency_ms =
        dataset("latency").empty() ? std::nullopt : MedianLatencyMs(dataset("latency"));
    d.settling = StudySettling(dataset("step_response"),
                               d.steps,
                               config,
                               d.result,
                               latency_ms,
                               delay,
                               o.fps,
                               &d.result.warnings,
                               d.resolution);
    if (d.settling) {
      const fitting::SettlingStudy& st = *d.settling;
      int agree = 0;
      for (const auto& r : st.rows) agree += r.agreement.rfind("agrees", 0) == 0;
      // The loop model's servo motion and where each number comes from (a prior is named).
      d.result.diagnostics["settling"] = {
          {"servo", st.servo >= 0 ? models::kServoNames[st.servo] : ""},
          {"slew_us_per_s", st.model.slew_us_per_s},
          {"slew_deg_per_s", st.model.slew_us_per_s * st.deg_per_us},
          {"slew_sigma_us_per_s",
           st.motion.slew_from_prior ? nlohmann::json(nullptr) : nlohmann::json(st.motion.slew_sigma_us_per_s)},
          {"slew_determined", st.motion.slew_determined},
          {"slew_source", st.slew_source},
          {"lag_s", st.model.lag_s},
          {"lag_sigma_s", st.motion.lag_from_prior ? nlohmann::json(nullptr) : nlohmann::json(st.motion.lag_sigma_s)},
          {"lag_determined", st.motion.lag_determined},
          {"lag_source", st.lag_source},
          {"exposure_delay_s", st.model.exposure_delay_s},
          {"groups", st.rows.size()},
          {"groups_agree", agree}};
      auto source = [](const std::string& s) { return s == "fitted" ? std::string() : " (" + s + ")"; };
      progress("settling: loop model (slew " + Fmt(st.model.slew_us_per_s * st.deg_per_us, 4) + " deg/s" +
               source(st.slew_source) + ", lag " + Fmt(1000 * st.model.lag_s, 3) + " ms" + source(st.lag_source) +
               ", exposure delay " + Fmt(1000 * d.settling->model.exposure_delay_s, 3) + " ms) agrees with " +
               std::to_string(agree) + " of " + std::to_string(d.settling->rows.size()) + " (gain, step) groups");
    }
  }
  return d;
}

void FinishCalibration(const std::map<std::string, std::string>& datasets,
                       const CalibratePipelineOptions& o,
                       fitting::CalibrationRun* run) {
  auto progress = [&](const std::string& m) {
    if (o.progress) o.progress(m);
  };
  auto dataset = [&](const char* name) -> std::string {
    const auto it = datasets.find(name);
    return it == datasets.end() ? std::string() : it->second;
  };
  fitting::CalibrationRun& d = *run;
  const models::RobotConfig& config = o.config;
  if (!dataset("saccade").empty()) AddSaccadeEvaluation(dataset("saccade"), o, &d);
  if (!dataset("limits").empty()) {
    std::vector<std::string> failed;
    int rows = 0;
    const auto measured = ReadLimits(dataset("limits"), &failed, &rows);
    d.limits = fitting::EvaluateLimits(o.bring_up ? o.bring_up->file : config, measured, &*d.result.head);
    d.limits->notes.insert(d.limits->notes.begin(),
                           "limit probes: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows));
    for (const auto& f : failed) {
      d.limits->notes.push_back("not measured: " + f);
      d.result.warnings.push_back("limits: not measured: " + f);
    }
    progress("limits: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows) + " ends, " +
             std::to_string(d.limits->notes.size()) + " notes");
  }
  // 5) Checks against references.
  AddReferenceChecks(dataset("latency"), dataset("alignment"), o, &d);
  d.result.inputs["datasets"] = datasets;
  d.result.inputs["pipeline"] = o.ToJson();
}

fitting::CalibrationRun CalibrateFromDatasets(const std::map<std::string, std::string>& datasets,
                                              const CalibratePipelineOptions& o) {
  fitting::CalibrationRun d = FitCalibration(datasets, o);
  FinishCalibration(datasets, o, &d);
  return d;
}

std::map<std::string, std::string> FindDatasets(const std::string& calibration_dir) {
  const fs::path root = fs::path(calibration_dir) / "datasets";
  if (!fs::is_directory(root)) throw NoDatasetsError(root.string() + ": missing (not a calibrate output folder)");
  std::vector<fs::path> dirs;
  for (const auto& e : fs::directory_iterator(root))
    if (e.is_directory() && fs::exists(e.path() / "manifest.json")) dirs.push_back(e.path());
  std::sort(dirs.begin(), dirs.end());
  std::map<std::string, std::string> out;
  for (const fs::path& dir : dirs) {
    const nlohmann::json m = protocols::ReadManifest(dir.string());
    const std::string where = (dir / "manifest.json").string();
    if (!m.contains("protocols") || !m["protocols"].is_array() || m["protocols"].size() != 1 ||
        !m["protocols"][0].contains("name") || !m["protocols"][0]["name"].is_string())
      throw NoDatasetsError(where + ": field 'protocols' does not hold exactly one protocol with a name");
    const std::string name = m["protocols"][0]["name"].get<std::string>();
    // calibrate names each dataset folder after its protocol file: keep that path, so a re-fit
    // records the same inputs.
    const std::string path = (fs::path(calibration_dir) / "datasets" / dir.filename()).string();
    if (!out.emplace(name, path).second)
      throw NoDatasetsError(where + ": a second dataset of protocol '" + name + "' (the first: " + out[name] + ")");
  }
  if (out.empty()) throw NoDatasetsError(root.string() + ": holds no dataset (no */manifest.json)");
  return out;
}

models::RobotConfig RobotConfigFromManifest(const nlohmann::json& manifest, const std::string& path) {
  if (!manifest.contains("robot") || !manifest["robot"].is_object() || !manifest["robot"].contains("config"))
    throw std::runtime_error(path + ": field 'robot.config' is missing");
  try {
    return fitting::RobotConfigFromJson(manifest["robot"]["config"]);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": field 'robot.config': " + e.what());
  }
}

}  // namespace owlcal::pipeline
