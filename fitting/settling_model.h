#pragma once
// Predicted versus measured 2 % settling of the fixation loop, per gain and step amplitude, and
// why they differ.
//
// Three numbers per (gain, amplitude):
//   measured   the step trials of the step-response protocol (fitting/step_response.h metrics
//              with the band of fitting/loop_model.h SettlingBand): median and min-max over the
//              trials that ran (status ok), "n ok of N";
//   loop model fitting/loop_model.h with the measured latency, the slew and lag fitted from the
//              step frames (fitting/servo_motion_fit.h), the servo's PWM step, dead band and
//              backlash, the controller's dead zone and the pixel noise: median and min-max over
//              simulations that vary the exposure delay over its uncertainty and the noise;
//   course     the ideal delayed P loop y(k+1) = y(k) + K (1 - y(k - d)) (fitting/ploop_analysis.h)
//              with d from the latency protocol (a first motion in frame d + 1 after the
//              command), its settling time counted from the first frame (index + d frames).
// "Agrees" when the measured median lies inside the loop model's range widened by one frame.
// The explanation attributes the gap between the course model and the loop model by switching
// parts of the loop model off: an ideal servo (no slew limit, no lag), no dead zone or PWM step
// (each variant's median over the same exposure delays and noise seeds as the loop model), and
// says which trials the loop model does not explain. An ideal servo settles LATER than the fitted
// one at gains below the no-overshoot gain (e.g. 1.0 vs 0.8 s at K = 0.1, d = 3): real, not a bug:
// slew and lag act as extra delay, the command runs ahead of the image and the target enters the
// band sooner (the course model: K = 0.1 settles in 22 frames with d = 3, 15 with d = 4); the
// "why" text says so.
#include <string>
#include <vector>

#include "fitting/loop_model.h"
#include "fitting/servo_motion_fit.h"
#include "fitting/step_response.h"

namespace owlcal::fitting {

struct SettlingOptions {
  int frames = 75;                // frames per simulated trial (the protocol's trial length)
  int noise_seeds = 3;            // simulations per exposure delay
  double delay_spread_s = 0.004;  // +- exposure delay (at least the fit's 2 sigma is used)
  std::vector<double> curve_gains = {0.02, 0.05, 0.08, 0.1, 0.13, 0.16, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5};
  bool Check(std::string* why) const;
};

struct SettlingRow {
  double gain = 0, amplitude_deg = 0;
  int num_trials = 0, num_ok = 0, num_settled = 0;  // num_ok: trials that ran to the end (ok or not settled)
  double measured_median_s = 0, measured_lo_s = 0, measured_hi_s = 0;  // NaN: no settled trial
  int predicted_settled = 0, predicted_runs = 0;
  double predicted_median_s = 0, predicted_lo_s = 0, predicted_hi_s = 0;  // NaN: none settled
  double ideal_s = 0;  // course model; NaN when unstable or not settled
  bool ideal_stable = false;
  double band = 0.02;              // settling band used (fraction of the step)
  double no_servo_dynamics_s = 0;  // loop model with an ideal servo (median, as predicted_median_s)
  double no_dead_zone_s = 0;       // loop model without dead zone, PWM step and noise
  std::string agreement;           // "agrees", "measured slower", "measured faster", "no measurement", ...
  std::string why;
};

struct SettlingCurvePoint {
  double gain = 0, amplitude_deg = 0;
  double median_s = 0, lo_s = 0, hi_s = 0;  // NaN: not settled
  double ideal_s = 0;
};

struct SettlingStudy {
  LoopModel model;
  ServoMotionFit motion;
  double latency_ms = 0;       // the latency protocol's median first-motion delay
  int ideal_delay_frames = 3;  // d of the course model
  double deg_per_us = 0.113;   // to state slew in deg/s
  int servo = -1;              // the servo the trials stepped (models::ServoIndex), -1 unknown
  // Where the model's slew and lag come from: "fitted" (from the step frames), "prior" (the
  // steps do not determine it: fitting/servo_motion_fit.h holds it at the prior) or "fitted, not
  // determined" (no prior given).
  std::string slew_source = "fitted", lag_source = "fitted";
  std::vector<SettlingRow> rows;
  std::vector<SettlingCurvePoint> curve;
  std::vector<std::string> notes;
};

// `measured`: step traces with status; their info must use SettlingBand(model, step). amplitude
// in degrees is converted to pulses with `deg_per_us`.
SettlingStudy CompareSettling(const LoopModel& model,
                              const ServoMotionFit& motion,
                              const std::vector<StepTrace>& measured,
                              int ideal_delay_frames,
                              double latency_ms,
                              double deg_per_us,
                              const SettlingOptions& options = {});

}  // namespace owlcal::fitting
