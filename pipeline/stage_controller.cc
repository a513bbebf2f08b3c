// Stage 4 of the calibration, the controller: the gain study, step responses and the loop model;
// then the limits and the checks against references (pipeline/calibrate_stages.h).
#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include "calib/trial_status.h"
#include "evaluation/limits_eval.h"
#include "evaluation/reference_checks.h"
#include "fitting/ploop_analysis.h"
#include "fitting/step_response.h"
#include "pipeline/bring_up.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/settling_study.h"
#include "protocols/dataset_tables.h"
#include "protocols/protocol.h"
#include "reports/table.h"

namespace owlcal::pipeline {

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

namespace stages {
namespace {

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
// datasheet: results.json diagnostics.reference_checks (evaluation/reference_checks.h).
void ReferenceChecks(const std::string& latency_dir,
                     const std::string& alignment_dir,
                     const CalibratePipelineOptions& o,
                     evaluation::CalibrationRun* d) {
  nlohmann::json checks = nlohmann::json::object();
  if (!latency_dir.empty()) {
    std::vector<evaluation::LatencyTrial> trials;
    for (const protocols::LatencyRow& row : protocols::ReadLatencyCsv(latency_dir)) {
      evaluation::LatencyTrial t;
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
    checks["latency"] = evaluation::ToJson(evaluation::CheckLatency(trials, o.latency_truth));
  }
  if (!alignment_dir.empty()) {
    std::vector<evaluation::AlignmentFrame> frames;
    for (const protocols::AlignmentRow& row : protocols::ReadAlignmentCsv(alignment_dir))
      frames.push_back({row.method, row.roll_deg, row.vertical_offset_px, row.horizontal_offset_px});
    // The offset in us of tilt: the fitted focal length and tilt scale when there are, else nominal.
    double focal = protocols::NominalFocalPx(o.config);
    if (d->result.cameras[0]) focal = d->result.cameras[0]->params[1];
    double deg_per_us = o.config.servos[models::kLy].nominal_deg_per_us;
    if (const fitting::Parameter* p = d->result.Find("servo.Ly.deg_per_us"); p && p->determined) deg_per_us = p->value;
    checks["alignment"] =
        evaluation::ToJson(evaluation::CheckAlignment(frames, o.config.image_width, focal, deg_per_us));
  }
  if (d->result.cameras[0] || d->result.cameras[1]) {
    std::optional<std::array<models::CameraIntrinsics, 2>> truth;
    if (o.truth) truth = std::array<models::CameraIntrinsics, 2>{o.truth->intrinsics[0], o.truth->intrinsics[1]};
    checks["field_of_view"] = evaluation::ToJson(evaluation::CheckFieldOfView(d->result, truth));
  }
  if (!checks.empty()) d->result.diagnostics["reference_checks"] = checks;
}

}  // namespace

void EvaluateSteps(const Inputs& in, evaluation::CalibrationRun* run) {
  using reports::Fmt;
  const CalibratePipelineOptions& o = in.options;
  const models::RobotConfig& config = o.config;
  int delay = o.default_delay_frames;
  if (!in.Dataset("latency").empty())
    if (auto lf = LatencyFrames(in.Dataset("latency"), o.fps)) delay = *lf;
  run->gains = fitting::MakeGainStudy(delay, o.fps);
  if (!in.Dataset("step_response").empty()) {
    run->steps = ReadStepTraces(in.Dataset("step_response"));
    for (const auto& st : run->steps)
      if (st.status != calib::TrialStatus::kOk)
        run->result.warnings.push_back("step trial (gain " + Fmt(st.gain, 3) + ", " + Fmt(st.amplitude_deg, 3) +
                                       " deg, trial " + std::to_string(st.trial) + ") " +
                                       calib::TrialStatusName(st.status) + ": " + st.reason);
    in.Progress("step responses: " + std::to_string(run->steps.size()) + " trials; delay " + std::to_string(delay) +
                " frames, K_crit " + Fmt(run->gains->critical_gain, 3));
    const std::optional<double> latency_ms =
        in.Dataset("latency").empty() ? std::nullopt : MedianLatencyMs(in.Dataset("latency"));
    run->settling = StudySettling(in.Dataset("step_response"),
                                  run->steps,
                                  config,
                                  run->result,
                                  latency_ms,
                                  delay,
                                  o.fps,
                                  &run->result.warnings,
                                  run->resolution);
    if (run->settling) {
      const fitting::SettlingStudy& st = *run->settling;
      int agree = 0;
      for (const auto& r : st.rows) agree += r.agreement.rfind("agrees", 0) == 0;
      // The loop model's servo motion and where each number comes from (a prior is named).
      run->result.diagnostics["settling"] = {
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
      in.Progress("settling: loop model (slew " + Fmt(st.model.slew_us_per_s * st.deg_per_us, 4) + " deg/s" +
                  source(st.slew_source) + ", lag " + Fmt(1000 * st.model.lag_s, 3) + " ms" + source(st.lag_source) +
                  ", exposure delay " + Fmt(1000 * run->settling->model.exposure_delay_s, 3) + " ms) agrees with " +
                  std::to_string(agree) + " of " + std::to_string(run->settling->rows.size()) + " (gain, step) groups");
    }
  }
}

void EvaluateLimits(const Inputs& in, evaluation::CalibrationRun* run) {
  const CalibratePipelineOptions& o = in.options;
  const models::RobotConfig& config = o.config;
  if (!in.Dataset("limits").empty()) {
    std::vector<std::string> failed;
    int rows = 0;
    const auto measured = LimitMeasurements(protocols::ReadLimitsCsv(in.Dataset("limits")), &failed, &rows);
    run->limits = evaluation::EvaluateLimits(o.bring_up ? o.bring_up->file : config, measured, &*run->result.head);
    run->limits->notes.insert(run->limits->notes.begin(),
                              "limit probes: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows));
    for (const auto& f : failed) {
      run->limits->notes.push_back("not measured: " + f);
      run->result.warnings.push_back("limits: not measured: " + f);
    }
    in.Progress("limits: " + std::to_string(measured.size()) + " ok of " + std::to_string(rows) + " ends, " +
                std::to_string(run->limits->notes.size()) + " notes");
  }
}

void AddReferenceChecks(const Inputs& in, evaluation::CalibrationRun* run) {
  ReferenceChecks(in.Dataset("latency"), in.Dataset("alignment"), in.options, run);
}

}  // namespace stages
}  // namespace owlcal::pipeline
