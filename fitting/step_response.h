#pragma once
// Step-response metrics of a sampled response, defined like MATLAB's stepinfo(y, t, yfinal,
// yinit) with an explicit initial value (docs/conventions.md, Facts "Step-response metrics").
//
// Let step = y_final - y_init (y_init defaults to y[0], y_final to the last sample) and
// e(t) = (y(t) - y_init) / step, the normalised response (0 at rest, 1 at the final value).
//   rise_time          time from the first sample with e >= rise_low (10 %) to the first
//                      sample with e >= rise_high (90 %); both linearly interpolated between
//                      samples [s, or frames when t is a frame index].
//   settling_time      t of the first sample from which every later sample satisfies
//                      |y - y_final| <= settling_band * |step| (2 %), measured from t[0]; no
//                      interpolation, so a frame-sampled loop settles "at frame k".
//   overshoot_pct      100 * max(0, max_k e_k - 1): beyond the final value, % of the step.
//   undershoot_pct     100 * max(0, -min_k e_k): the wrong-way excursion, % of the step.
//   peak, peak_time    the sample with the largest e (the value of y, not normalised).
//   steady_state_error reference - y_final (reference defaults to y_final: 0).
// A response that never enters the band for good has settled = false and settling_time NaN;
// one that never reaches 90 % has rise_time NaN. Times are relative to t[0].
//
// Usage:
//   StepInfoOptions o; o.y_init = 0.0; o.y_final = 1.0;
//   StepInfo s = ComputeStepInfo(t, y, o);
#include <optional>
#include <string>
#include <vector>

#include "calib/trial_status.h"

namespace owlcal::fitting {

struct StepInfoOptions {
  std::optional<double> y_init;     // default: y[0]
  std::optional<double> y_final;    // default: y.back()
  std::optional<double> reference;  // the commanded value; default y_final
  double settling_band = 0.02;      // fraction of |step|
  double rise_low = 0.1, rise_high = 0.9;

  bool Check(std::string* why) const;
};

struct StepInfo {
  double y_init = 0, y_final = 0;
  double rise_time = 0;
  double settling_time = 0;
  int settling_index = -1;  // index of the settling sample; -1 when not settled
  bool settled = false;
  double overshoot_pct = 0;
  double undershoot_pct = 0;
  double peak = 0;
  double peak_time = 0;
  double steady_state_error = 0;
};

// Throws std::invalid_argument when t and y differ in length, have fewer than 2 samples,
// t is not increasing, the options fail Check, or the step is zero.
StepInfo ComputeStepInfo(const std::vector<double>& t,
                         const std::vector<double>& y,
                         const StepInfoOptions& options = {});

// One measured (or simulated) fixation step response: y is the fraction of the step done (0 at
// rest, 1 on target), computed from the target's image offset.
struct StepTrace {
  double gain = 0;
  double amplitude_deg = 0;
  int trial = 0;
  std::string eye_axis;                                 // "right pan"
  calib::TrialStatus status = calib::TrialStatus::kOk;  // as the protocol recorded the trial
  std::string reason;                                   // why not ok
  std::string controller = "p-loop";                    // "p-loop" or "saccade" (fitting/settling_model.h)
  double band = 0.02;                                   // settling band used (fraction of the step)
  std::vector<double> t_s;                              // from the step command
  std::vector<double> y;
  double residual_px = 0;  // |target offset| after settling
  StepInfo info;           // of (t_s, y) with y_init 0, y_final 1
  bool simulated = false;
};

// Unit-step response of an underdamped or overdamped second-order system
// wn^2 / (s^2 + 2 zeta wn s + wn^2) at time t >= 0 (closed form), for tests and figures.
double SecondOrderStep(double zeta, double wn, double t);

// Closed-form stepinfo figures of that system (zeta < 1): overshoot 100 exp(-pi zeta /
// sqrt(1 - zeta^2)) %, peak time pi / (wn sqrt(1 - zeta^2)).
double SecondOrderOvershootPct(double zeta);
double SecondOrderPeakTime(double zeta, double wn);

}  // namespace owlcal::fitting
