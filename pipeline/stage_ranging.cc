// Stage 4 of the calibration, ranging: the servos' PWM step and dead band, then every fixation of
// the vergence dataset ranged (pipeline/calibrate_stages.h).
#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/trial_status.h"
#include "evaluation/ranging_eval.h"
#include "fitting/servo_resolution_fit.h"
#include "models/head_kinematics.h"
#include "pipeline/calibrate_stages.h"
#include "protocols/dataset.h"
#include "protocols/dataset_tables.h"
#include "protocols/fixation.h"
#include "protocols/protocol.h"
#include "reports/table.h"

namespace owlcal::pipeline::stages {
namespace {

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

std::vector<evaluation::Fixation> ReadFixations(const std::string& dataset,
                                                const models::RobotConfig& config,
                                                const std::optional<models::HeadModel>& truth,
                                                const models::HeadModel& fitted,
                                                std::vector<std::string>* excluded) {
  std::vector<evaluation::Fixation> out;
  const std::vector<protocols::FixationRow> rows = protocols::ReadFixationsCsv(dataset);
  const auto placements = protocols::ReadPlacementsCsv(dataset);
  const std::map<std::string, Eigen::Vector3d> aim = AimPointsOfDataset(dataset);
  const double cx = (config.image_width - 1) / 2.0, cy = (config.image_height - 1) / 2.0;
  for (size_t r = 0; r < rows.size(); ++r) {
    const protocols::FixationRow& row = rows[r];
    // Every fixation is a row of the ranging table with its status; only "ok" is ranged. Older
    // datasets have no status column: it follows from the outcome.
    evaluation::Fixation f;
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
void ApplyResolution(const std::vector<fitting::ServoResolutionResult>& resolution, evaluation::Fixation* f) {
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

}  // namespace

void EvaluateResolutionAndRanging(const Inputs& in, evaluation::CalibrationRun* run) {
  using reports::Fmt;
  const CalibratePipelineOptions& o = in.options;
  const models::RobotConfig& config = o.config;
  if (!in.Dataset("limits").empty()) {
    run->resolution = FitResolution(in.Dataset("limits"), &run->result);
    for (const auto& r : run->resolution)
      in.Progress("servo resolution " + std::string(models::kServoNames[r.servo]) + ": " +
                  (r.fit.ok ? fitting::DescribeResolution(r.fit) : r.fit.message) +
                  (r.fit.ok && !r.fit.determined ? " (not determined)" : ""));
  }
  if (!in.Dataset("vergence").empty()) {
    std::vector<std::string> excluded;
    auto fixations = ReadFixations(in.Dataset("vergence"), config, o.truth, *run->result.head, &excluded);
    for (auto& f : fixations) ApplyResolution(run->resolution, &f);
    for (const auto& x : excluded) run->result.warnings.push_back(x);
    const fitting::NamedCovariance cov =
        fitting::CovarianceFromResult(run->result, evaluation::RangingParameterNames());
    std::vector<double> theory;
    for (double x = o.theory_min_m; x <= o.theory_max_m + 1e-4; x += o.theory_step_m) theory.push_back(x);
    run->ranging = evaluation::EvaluateRanging(*run->result.head, cov, config, fixations, {}, theory);
    // No error figure without a ranged fixation (an RMS of nothing is not 0 %).
    const int tried = int(run->ranging->rows.size());
    if (tried == 0)
      in.Progress("ranging: no fixation recorded (the vergence dataset has none: see the warnings)");
    else if (run->ranging->num_ok == 0)
      in.Progress("ranging: 0 of " + std::to_string(tried) +
                  " fixations ranged (the reasons are in the ranging table)");
    else
      in.Progress("ranging: " + std::to_string(run->ranging->num_ok) + " of " + std::to_string(tried) +
                  " fixations, RMS error " + Fmt(100 * run->ranging->rms_rel_error, 3) + " %, " +
                  Fmt(100 * run->ranging->fraction_within_2sigma, 3) + " % within 2 sigma (course method " +
                  Fmt(100 * run->ranging->nominal_rms_rel_error, 3) + " %)");
  }
}

}  // namespace owlcal::pipeline::stages
