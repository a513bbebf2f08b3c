#include "pipeline/saccade_study.h"

#include <algorithm>
#include <cmath>

#include "calib/trial_status.h"
#include "fitting/step_response.h"
#include "models/head_model.h"
#include "models/units.h"
#include "protocols/dataset_tables.h"
#include "protocols/protocol.h"
#include "reports/table.h"

namespace owlcal::pipeline {

protocols::CalibratedMaps ControllerCalibration(const evaluation::CalibrationRun& run, const std::string& source) {
  protocols::CalibratedMaps c;
  c.head = run.result.head ? *run.result.head : models::NominalHeadModel(run.config);
  c.source = run.result.head ? source : source + ", no head fit: nominal head";
  if (run.settling && run.settling->servo >= 0 && run.settling->servo < models::kNumServos) {
    const int i = run.settling->servo;
    c.slew_us_per_s[i] = run.settling->model.slew_us_per_s;
    c.lag_s[i] = run.settling->model.lag_s;
    c.exposure_delay_s = run.settling->model.exposure_delay_s;
  }
  for (const fitting::ServoResolutionResult& r : run.resolution)
    if (r.fit.ok && r.fit.determined && r.servo >= 0 && r.servo < models::kNumServos) {
      c.resolution_us[r.servo] = std::max(r.fit.resolution.step_us, r.fit.resolution.dead_band_us);
      c.pwm_step_us[r.servo] = r.fit.resolution.step_us;
    }
  return c;
}

void AddSaccadeEvaluation(const std::string& dataset,
                          const CalibratePipelineOptions& o,
                          evaluation::CalibrationRun* run) {
  using reports::Fmt;
  std::vector<fitting::StepTrace> traces = ReadStepTraces(dataset);
  if (traces.empty()) {
    run->result.warnings.push_back("saccade dataset " + dataset + " holds no trial");
    return;
  }
  int servo = -1;
  for (const protocols::StepTrialRow& row : protocols::ReadStepTrialsCsv(dataset))
    if (const int s = protocols::ServoIndexFromName(row.servo); s >= 0) servo = s;
  double amplitude = traces.front().amplitude_deg;
  // Settled within 2 % of the step, or within half the servo's resolution (its PWM step or dead
  // band) plus twice the image noise when that is wider: no command can put the target closer.
  double half_pulse_px = 0, noise_px = 0.05, focal_px = 0;
  if (servo >= 0) {
    // The head and the resolution the controller was given (ControllerCalibration above).
    const protocols::CalibratedMaps cal = ControllerCalibration(*run, "");
    const models::HeadModel& head = cal.head;
    const int eye = servo == models::kPanServo[models::kLeftEye] || servo == models::kTiltServo[models::kLeftEye]
                        ? models::kLeftEye
                        : models::kRightEye;
    focal_px = head.intrinsics[eye].params[0];
    half_pulse_px =
        0.5 * cal.resolution_us[servo] * focal_px * std::tan(std::abs(head.servo_params[servo][1]) * kDegToRad);
    if (run->settling) noise_px = std::max(noise_px, run->settling->model.noise_px);
  }
  for (fitting::StepTrace& t : traces) {
    t.controller = "saccade";
    t.eye_axis = "saccade";
    const double step_px = focal_px * std::tan(std::min(80.0, std::abs(t.amplitude_deg)) * kDegToRad);
    if (t.t_s.size() >= 3 && step_px > 0) {
      const double band = std::max(0.02, (half_pulse_px + 2 * noise_px) / step_px);
      if (band > 0.02) {
        t.band = band;
        fitting::StepInfoOptions so;
        so.y_init = 0.0;
        so.y_final = 1.0;
        so.settling_band = band;
        t.info = fitting::ComputeStepInfo(t.t_s, t.y, so);
      }
    }
    if (std::abs(std::abs(t.amplitude_deg) - 10) < 1e-6) amplitude = 10;
    if (t.status != calib::TrialStatus::kOk)
      run->result.warnings.push_back("saccade trial (" + Fmt(t.amplitude_deg, 3) + " deg, trial " +
                                     std::to_string(t.trial) + ") " + calib::TrialStatusName(t.status) + ": " +
                                     t.reason);
    run->steps.push_back(t);
  }
  // The bound's numbers: the truth on the virtual Owl, else the fitted motion.
  const bool truth = servo >= 0 && o.truth_slew_deg_per_s[servo] > 0 && o.truth_latency_s > 0;
  const bool fitted = run->settling && run->settling->model.slew_us_per_s > 0;
  const double fitted_slew = fitted ? run->settling->model.slew_us_per_s * run->settling->deg_per_us : 0;
  const double fitted_delay = fitted ? run->settling->model.exposure_delay_s : 0;
  const double slew = truth ? o.truth_slew_deg_per_s[servo] : fitted_slew;
  const double delay = truth ? o.truth_latency_s : fitted_delay;
  evaluation::SaccadeEvaluation ev = evaluation::EvaluateSaccades(run->steps, amplitude, slew, delay, o.fps);
  if (truth)
    ev.notes.insert(
        ev.notes.begin(),
        "bound from the virtual Owl's truth: " + std::string(models::kServoNames[servo]) + " slew " + Fmt(slew, 4) +
            " deg/s, stream latency " + Fmt(1000 * delay, 4) + " ms, " + Fmt(o.fps, 3) + " fps" +
            (fitted
                 ? " (with the motion fitted from the step frames, slew " + Fmt(fitted_slew, 4) +
                       " deg/s and exposure delay " + Fmt(1000 * fitted_delay, 4) + " ms, it would be " +
                       Fmt(1000 * fitting::PhysicalLowerBoundS(amplitude, fitted_slew, fitted_delay, o.fps), 4) + " ms)"
                 : ""));
  else if (fitted)
    ev.notes.insert(ev.notes.begin(),
                    "bound from the motion fitted from the step frames: slew " + Fmt(slew, 4) +
                        " deg/s, exposure delay " + Fmt(1000 * delay, 4) + " ms, " + Fmt(o.fps, 3) + " fps");
  else
    ev.notes.insert(ev.notes.begin(), "no bound: neither a truth nor a fitted slew (no step-response dataset)");
  if (o.progress)
    o.progress("saccade: " + std::to_string(ev.num_settled) + " of " + std::to_string(ev.num_trials) + " " +
               Fmt(amplitude, 3) + " deg trials settled, median " + Fmt(1000 * ev.median_s, 4) +
               " ms = " + Fmt(ev.ratio_to_bound, 3) + " x the bound " + Fmt(1000 * ev.bound_s, 4) +
               " ms; P loop at K = " + Fmt(ev.ploop_gain, 3) + ": " + Fmt(1000 * ev.ploop_median_s, 4) + " ms");
  run->saccade = ev;
}

}  // namespace owlcal::pipeline
