// owlcal calibrate [--robot sim|HOST] [--robot-truth FILE] [--seed N] --out DIR: the main job.
// Runs the standard protocol suite (one dataset per protocol under DIR/datasets/), fits
// intrinsics + stereo (fitting/stereo_fit.h) and the head (fitting/head_fit.h), evaluates
// ranging, step responses, gains and limits (fitting/*_eval.h), compares with the truth on
// the virtual Owl, and writes DIR/results.json, DIR/evaluation.json, DIR/calibration.yaml,
// DIR/intrinsics.xml and extrinsics.xml (the course's files, mm), DIR/exports/, DIR/figures/,
// DIR/tables/ and DIR/report/index.html.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>

#include "apps/command_registry.h"
#include "apps/robot_options.h"
#include "calib/observation.h"
#include "calib/observation_io.h"
#include "calib/trial_status.h"
#include "fitting/fit_points.h"
#include "fitting/head_fit.h"
#include "fitting/limits_eval.h"
#include "fitting/ranging_eval.h"
#include "fitting/stereo_fit.h"
#include "fitting/stereo_sanity.h"
#include "fitting/step_response.h"
#include "fitting/truth_compare.h"
#include "models/head_kinematics.h"
#include "owlcal_version.h"
#include "protocols/dataset.h"
#include "protocols/dataset_tables.h"
#include "protocols/placement_views.h"
#include "protocols/protocol.h"
#include "protocols/robot_factory.h"
#include "protocols/runner.h"
#include "reports/exports.h"
#include "reports/report.h"
#include "reports/report_data.h"
#include "sim/virtual_owl.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct CalibrateOptions {
  RobotOptions robot;
  std::string out;
  std::vector<std::string> protocols;  // default: the standard suite
  bool non_interactive = false;
  bool no_figures = false;
  bool quiet = false;
};

class Progress {
 public:
  explicit Progress(bool quiet) : quiet_(quiet), t0_(std::chrono::steady_clock::now()) {}
  void operator()(const std::string& msg) const {
    if (quiet_) return;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    std::cout << "[calibrate " << std::fixed;
    std::cout.precision(1);
    std::cout << s << " s] " << msg << std::endl;
    std::cout.unsetf(std::ios::fixed);
  }
  double Elapsed() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }

 private:
  bool quiet_;
  std::chrono::steady_clock::time_point t0_;
};

std::vector<calib::CornerObservation> ReadObs(const std::string& dataset) {
  const std::string p = dataset + "/observations.csv";
  if (!fs::exists(p)) return {};
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

std::vector<fitting::Fixation> ReadFixations(const std::string& dataset,
                                             const models::RobotConfig& config,
                                             const std::optional<models::HeadModel>& truth,
                                             const models::HeadModel& fitted,
                                             std::vector<std::string>* excluded) {
  std::vector<fitting::Fixation> out;
  const std::vector<protocols::FixationRow> rows = protocols::ReadFixationsCsv(dataset);
  const auto placements = protocols::ReadPlacementsCsv(dataset);
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
    for (int e = 0; e < 2; ++e)
      if (found[e]) f.target_px[e] = Eigen::Vector2d(cx, cy) + *row.offset_px[e];
    // True distance: from the placement pose (base frame) to the midpoint of the eye centres
    // (the truth's on the virtual Owl, else the fitted head's); else the logged distance.
    const models::HeadModel& ref = truth ? *truth : fitted;
    const double neck = ref.ServoAngle(models::kNeck, f.pwm_us[models::kNeck]);
    const Eigen::Vector3d mid = models::HeadFromBase(neck).Inverse() *
                                (0.5 * (ref.geometry.centre_in_head[0] + ref.geometry.centre_in_head[1]));
    f.true_distance_m = row.distance_m.value_or(NAN);
    for (const auto& p : placements)
      if (p.placement_index == row.placement_index) f.true_distance_m = (p.base_from_target.translation() - mid).norm();
    if (!std::isfinite(f.true_distance_m) && f.status == calib::TrialStatus::kOk) {
      f.status = calib::TrialStatus::kSkipped;
      f.reason = "no true distance (no placement or distance_m)";
    }
    if (f.status != calib::TrialStatus::kOk)
      excluded->push_back("vergence fixation " + std::to_string(r) + " (fixations.csv line " + std::to_string(row.line) +
                          ") not ranged: " + calib::TrialStatusName(f.status) + ": " + f.reason);
    out.push_back(f);
  }
  return out;
}

std::vector<fitting::StepTrace> ReadSteps(const std::string& dataset) {
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

// The measured ends; *failed names every probe row that measured nothing (status not ok, or no
// number), *num_rows counts them all ("n ok of N").
std::vector<fitting::LimitMeasurement> ReadLimits(const std::string& dataset, std::vector<std::string>* failed,
                                                  int* num_rows) {
  std::vector<fitting::LimitMeasurement> out;
  const std::vector<protocols::LimitRow> rows = protocols::ReadLimitsCsv(dataset);
  *num_rows = int(rows.size());
  for (const protocols::LimitRow& row : rows) {
    const std::string what = row.servo + " " + row.end + " (limits.csv line " + std::to_string(row.line) + ")";
    const int s = protocols::ServoIndexFromName(row.servo);
    fitting::LimitMeasurement m;
    m.servo = s;
    m.high_end = row.end == "max";
    m.cause = fitting::LimitCauseFromName(row.cause);
    if (s < 0 || (row.status && *row.status != calib::TrialStatus::kOk) || !row.measured_us) {
      failed->push_back(what + ": " + (row.status ? calib::TrialStatusName(*row.status) : "no measurement") +
                        (row.message.empty() ? "" : ": " + row.message));
      continue;
    }
    m.measured_us = *row.measured_us;
    out.push_back(m);
  }
  return out;
}

// Median latency in frames from latency.csv; nullopt without data.
std::optional<int> LatencyFrames(const std::string& dataset, double fps) {
  std::vector<double> v;
  for (const protocols::LatencyRow& row : protocols::ReadLatencyCsv(dataset))
    if (row.latency_ms) v.push_back(*row.latency_ms);
  if (v.empty()) return std::nullopt;
  std::sort(v.begin(), v.end());
  return std::max(1, int(std::lround(v[v.size() / 2] * fps / 1000.0)));
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
      for (int j = 0; j < h.covariance.cols(); ++j) row[j] = std::isfinite(h.covariance(i, j)) ? h.covariance(i, j) : 0.0;
      m.push_back(row);
    }
    r->diagnostics["covariance"] = {{"names", h.param_names}, {"matrix", m}, {"source", "head fit"}};
  }
}

int RunCalibrate(const CalibrateOptions& o) {
  if (o.out.empty()) throw UsageError("--out DIR is required");
  if (fs::exists(o.out + "/results.json")) throw UsageError(o.out + " already holds a calibration (results.json); choose a new --out");
  const Progress progress(o.quiet);
  fs::create_directories(o.out);
  std::vector<std::string> names = o.protocols.empty() ? protocols::StandardProtocolNames() : o.protocols;

  std::unique_ptr<robot::RobotInterface> robot = protocols::MakeRobot(o.robot.robot, o.robot.Factory());
  const models::RobotConfig config = robot->Config();
  progress("robot: " + robot->Describe());

  reports::ReportData d;
  d.config = config;
  d.result.software_version = OWLCAL_VERSION;
  d.settings = {{"command", "owlcal calibrate"}, {"robot", o.robot.robot}, {"robot_file", o.robot.robot_file},
                {"robot_truth", o.robot.robot_truth}, {"scene", o.robot.scene}, {"seed", o.robot.seed}, {"protocols", names},
                {"owlcal_version", OWLCAL_VERSION}};
  std::optional<sim::RobotTruth> truth;
  if (auto* owl = dynamic_cast<sim::VirtualOwl*>(robot.get())) truth = owl->Truth();

  // 1) Record one dataset per protocol.
  std::atomic<bool>* stop = protocols::InstallStopSignals();
  std::map<std::string, std::string> dataset;
  nlohmann::json run_info = nlohmann::json::object();
  for (const std::string& name : names) {
    const std::string dir = o.out + "/datasets/" + fs::path(name).stem().string();
    protocols::Protocol p;
    try {
      p = protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name));
    } catch (const protocols::ProtocolError& e) {
      throw UsageError(e.what());
    }
    progress("protocol " + p.name + " -> " + dir);
    protocols::RunOptions ro;
    ro.out_dir = dir;
    o.robot.FillRunOptions(&ro);
    ro.progress = nullptr;
    // A real robot: a person places the targets, prompted on the terminal (the prompt and the
    // answer are recorded in placements.csv); piped or --non-interactive: the protocol's poses
    // are assumed, and the dataset says so.
    ro.interactive = !o.robot.IsSim() && !o.non_interactive && ::isatty(STDIN_FILENO);
    ro.stop_flag = stop;
    const protocols::RunSummary s = protocols::RunProtocols({p}, *robot, ro);
    run_info[p.name] = {{"status", s.status}, {"frames", s.num_frames}, {"clamped", s.num_clamped},
                        {"robot_clock_s", s.elapsed_s}, {"message", s.message}};
    progress("  " + s.status + ", " + std::to_string(s.num_frames) + " frames, " + std::to_string(s.num_clamped) +
             " clamped commands");
    if (s.status == "aborted") throw std::runtime_error("stopped by the user; datasets so far are in " + o.out);
    if (s.status != "complete") d.result.warnings.push_back("protocol " + p.name + ": " + s.status + ": " + s.message);
    dataset[p.name] = dir;
  }
  d.settings["runs"] = run_info;

  // 2) Intrinsics + stereo from the intrinsics and stereo datasets.
  std::optional<fitting::StereoFit> stereo;
  {
    // The intrinsics capture moves the eyes, so its left/right frames do not share one
    // right_from_left: keep them unpaired (they constrain each eye's intrinsics only). Only the
    // stereo capture, taken at one fixed eye pose, pairs left with right.
    std::vector<calib::CornerObservation> obs = ReadObs(dataset.count("intrinsics") ? dataset["intrinsics"] : "");
    for (auto& c : obs)
      if (c.eye == models::kRightEye) c.frame_index += 2000000;
    if (dataset.count("stereo")) {
      for (auto c : ReadObs(dataset["stereo"])) {
        c.frame_index += 1000000;  // keep frames of the two datasets apart
        obs.push_back(c);
      }
    }
    const std::vector<calib::View> views = calib::GroupIntoViews(obs);
    std::vector<calib::View> l, r;
    SplitEyes(views, &l, &r);
    progress("stereo fit: " + std::to_string(l.size()) + " left and " + std::to_string(r.size()) + " right views");
    if (!l.empty() && !r.empty()) {
      fitting::StereoFitOptions so;
      stereo = fitting::FitStereo(l, r, so);
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
        progress("  RMS " + reports::Fmt(stereo->rms_px[0], 3) + " / " + reports::Fmt(stereo->rms_px[1], 3) + " px");
      } else {
        d.result.warnings.push_back("stereo fit failed: " + stereo->message);
        progress("  failed: " + stereo->message);
      }
    } else {
      d.result.warnings.push_back("no chessboard views: intrinsics and stereo not fitted");
    }
  }

  // 3) The head from the servo sweep.
  models::HeadModel initial = models::NominalHeadModel(config);
  for (int e = 0; e < 2; ++e)
    if (d.result.cameras[e]) initial.intrinsics[e] = *d.result.cameras[e];
  bool neck_moved = false;
  if (dataset.count("servo_sweep")) {
    // One board per placement: the sweep places the same chessboard at five poses.
    const auto views = protocols::ReadViewsByPlacement(dataset["servo_sweep"]);
    progress("head fit: " + std::to_string(views.size()) + " views");
    for (const auto& v : views) neck_moved |= v.pwm_us[models::kNeck] != config.servos[models::kNeck].centre_us;
    fitting::HeadFitOptions ho;
    // The intrinsics start from the stereo fit and are refined on the sweep (boards at four
    // distances over the whole image). Held, their errors are not in any sigma and bias the
    // pan zeros: the head-yaw gauge puts pan zero on the eye baseline, and a relative focal
    // length error of 2e-4 between the eyes moves one eye centre's depth by ~0.15 mm at 0.6 m,
    // 0.15 deg of both pan maps (virtual Owl: Rx/Lx 0.17/0.18 deg RMS held; refined, the
    // report's servo_map_truth table shows them, 0.03-0.04 deg).
    ho.fit_intrinsics = true;
    // Whitening: the noise the data shows, per eye (HeadFitOptions::estimate_corner_sigma),
    // not an assumed 0.15 px, which made the servo and head sigmas 3-7 x too large on the
    // virtual Owl (measured 0.021 px per axis on the default robot, 0.034-0.064 on rougher
    // ones). The measured sigma is then doubled for the detector's corner bias, which is nearly
    // the same on neighbouring views of a board and does not average away: sigma is widened
    // for it, not modelled. Factor 2 from calibrations of the default robot and variant A
    // (bench/robot_prior_mc_bench.cc shipped): whitened with the measured sigma alone, 44-52 % of
    // the head parameters lay within 1 sigma and up to 12 % beyond 3; doubled, 76-81 % within 1
    // and 97-100 % within 3 (slightly conservative, to cover the rougher robots' larger bias).
    // Hysteresis is floored at 0.01 us: frames exposed before a servo fully settled read as
    // extra backlash (+0.001-0.006 us on every servo of a slow robot), and lag is not modelled.
    ho.estimate_corner_sigma = true;
    ho.measured_sigma_factor = 2.0;
    ho.hysteresis_sigma_floor_us = 0.01;
    const fitting::HeadFit h = fitting::FitHead(views, config, initial, ho);
    if (h.ok) {
      MergeHead(h, &d.result);
      progress("  RMS " + reports::Fmt(h.result.summaries.empty() ? NAN : h.result.summaries.back().rms_px, 3) + " px, IPD " +
               reports::Fmt(d.result.Find("head.ipd_mm") ? d.result.Find("head.ipd_mm")->value : NAN, 5) + " mm");
    } else {
      d.result.warnings.push_back("head fit failed: " + h.message);
      progress("  failed: " + h.message);
    }
  }
  if (!d.result.head) {
    d.result.head = initial;
    d.result.warnings.push_back("no head fit: ranging uses the nominal head (configured centres, 0.113 deg/us)");
  }

  // 4) Truth (virtual Owl), in the fit's gauge.
  if (truth) {
    const models::HeadModel canonical = fitting::CanonicalHead(truth->HeadModel(), config.servos[models::kNeck].centre_us,
                                                               neck_moved, initial.geometry.centre_in_head[0]);
    d.truth = canonical;
    fitting::SetHeadTruth(canonical, &d.result);
    fitting::FillTruth(fitting::IntrinsicsTruthValues(truth->HeadModel()), &d.result);
    // The stereo truth at the stereo capture's command and approach (backlash side).
    models::PwmVector stereo_pwm = config.Centre();
    std::array<int, models::kNumServos> stereo_approach{};
    if (dataset.count("stereo")) {
      const auto obs = ReadObs(dataset["stereo"]);
      if (!obs.empty()) {
        stereo_pwm = obs.front().pwm_us;
        for (int s = 0; s < models::kNumServos; ++s) stereo_approach[s] = obs.front().approach[s];
      }
    }
    fitting::FillTruth(fitting::StereoTruthValues(truth->HeadModel(), stereo_pwm, stereo_approach), &d.result);
  }

  // 5) Evaluations.
  if (dataset.count("vergence")) {
    std::vector<std::string> excluded;
    const auto fixations = ReadFixations(dataset["vergence"], config,
                                         truth ? std::optional(truth->HeadModel()) : std::nullopt, *d.result.head, &excluded);
    for (const auto& x : excluded) d.result.warnings.push_back(x);
    const fitting::NamedCovariance cov = fitting::CovarianceFromResult(d.result, fitting::RangingParameterNames());
    std::vector<double> theory;
    for (double x = 0.2; x <= 2.0001; x += 0.05) theory.push_back(x);
    d.ranging = fitting::EvaluateRanging(*d.result.head, cov, config, fixations, {}, theory);
    progress("ranging: " + std::to_string(d.ranging->num_ok) + " fixations, RMS error " +
             reports::Fmt(100 * d.ranging->rms_rel_error, 3) + " %, " +
             reports::Fmt(100 * d.ranging->fraction_within_2sigma, 3) + " % within 2 sigma (course method " +
             reports::Fmt(100 * d.ranging->nominal_rms_rel_error, 3) + " %)");
  }
  const double fps = truth ? truth->stream.fps : 30.0;
  int delay = 3;
  if (dataset.count("latency"))
    if (auto lf = LatencyFrames(dataset["latency"], fps)) delay = *lf;
  d.gains = fitting::MakeGainStudy(delay, fps);
  if (dataset.count("step_response")) {
    d.steps = ReadSteps(dataset["step_response"]);
    for (const auto& st : d.steps)
      if (st.status != calib::TrialStatus::kOk)
        d.result.warnings.push_back("step trial (gain " + reports::Fmt(st.gain, 3) + ", " + reports::Fmt(st.amplitude_deg, 3) +
                                    " deg, trial " + std::to_string(st.trial) + ") " + calib::TrialStatusName(st.status) +
                                    ": " + st.reason);
    progress("step responses: " + std::to_string(d.steps.size()) + " trials; delay " + std::to_string(delay) +
             " frames, K_crit " + reports::Fmt(d.gains->critical_gain, 3));
  }
  if (dataset.count("limits")) {
    std::vector<std::string> failed;
    int rows = 0;
    const auto measured = ReadLimits(dataset["limits"], &failed, &rows);
    d.limits = fitting::EvaluateLimits(config, measured, &*d.result.head);
    d.limits->notes.insert(d.limits->notes.begin(),
                           "limit probes: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows));
    for (const auto& f : failed) {
      d.limits->notes.push_back("not measured: " + f);
      d.result.warnings.push_back("limits: not measured: " + f);
    }
    progress("limits: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows) + " ends, " +
             std::to_string(d.limits->notes.size()) + " notes");
  }
  d.result.inputs["datasets"] = dataset;

  // 6) Files.
  reports::WriteReportData(d, o.out);
  const reports::ExportSet ex = reports::WriteCalibrationFiles(d, o.out);
  for (const auto& s : ex.skipped) progress("export skipped: " + s);
  reports::ReportOptions ro;
  ro.draw = !o.no_figures;
  const reports::ReportOutput rep = reports::WriteReport(d, o.out, ro);
  for (const auto& w : rep.warnings) progress("report: " + w);
  if (truth) {
    const fitting::TruthComparison c = fitting::CompareWithTruth(d.result);
    progress("truth: " + std::to_string(c.num_with_sigma) + " parameters with sigma, " +
             reports::Fmt(100 * c.fraction_within_2sigma, 3) + " % within 2 sigma, worst " + c.worst + " (z = " +
             reports::Fmt(c.worst_z, 3) + ")");
  }
  progress("done: " + rep.index_html);
  return kExitOk;
}

const bool kRegistered = RegisterCommand(
    "calibrate",
    "The main job: run the standard suite, fit, evaluate and write the report folder.\n"
    "With no --robot it uses the in-process virtual Owl. Produces DIR/results.json (every\n"
    "parameter with value, sigma, unit and truth), DIR/calibration.yaml (OpenCV, metres),\n"
    "DIR/intrinsics.xml + extrinsics.xml (the course's files, mm), DIR/exports/ (ROS, Kalibr,\n"
    "mrcal, owl-pwm.h), DIR/figures/, DIR/tables/, DIR/report/index.html and the recorded\n"
    "datasets in DIR/datasets/.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CalibrateOptions>();
      AddRobotOptions(cmd, &o->robot);
      cmd->add_flag("--non-interactive", o->non_interactive,
                    "real robot: do not prompt; assume targets are placed as the protocols say");
      cmd->add_option("--protocols", o->protocols, "protocols to run instead of the standard suite");
      cmd->add_option("--out", o->out, "report folder to create")->required();
      cmd->add_flag("--no-figures", o->no_figures, "write figure data and scripts without running gnuplot");
      cmd->add_flag("--quiet", o->quiet, "no progress output");
      return [o] { return RunCalibrate(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
