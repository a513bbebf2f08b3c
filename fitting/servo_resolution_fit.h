#pragma once
// The PWM step and dead band of one servo (models/servo_resolution.h) from a fine sweep: the
// command is changed by a few microseconds at a time, up, down and up again, and after each
// settled command the image position along the servo's image axis is measured (the servo
// resolution protocol step, dataset resolution.csv).
//
// Model, for a candidate resolution R = (step, dead band, phase): replaying the commands
// through R from (Stepped(u_0), initial_approach) gives the applied pulse a_k and approach
// s_k of every sample, and
//   position_k = offset + px_per_us * (a_k - hysteresis_us * s_k)          [px]
// (the servo map is linear over the few tens of us swept; backlash as in models/servo_map.h).
// offset, px_per_us and hysteresis_us are fitted by linear least squares for every candidate
// step 1..max_step_us, phase 0..step-1 and dead band 1..max_dead_band_us; the candidate with
// the smallest residual wins. Candidates that replay to the same applied sequence (up to a
// constant) cannot be told apart: the simplest one is reported (smallest step, then dead
// band, then the rounding phase). With steps larger than 1 us the dead band is known only to
// within a step (a dead band of 2 us and one of 5 us ignore the same 5 us steps: none), so the
// fit reports the range of dead bands that replay identically. The fit is `determined` when every
// candidate with a different applied sequence leaves an RMS residual at least
// `min_rms_ratio` times larger and at least 0.3 px larger.
//
// Usage:
//   std::vector<ResolutionSample> s = ...;        // from resolution.csv, one servo
//   ResolutionFit f = FitServoResolution(s, {});
//   if (f.determined) use f.resolution;
#include <string>
#include <vector>

#include "models/servo_resolution.h"

namespace owlcal::fitting {

struct ResolutionSample {
  int command_us = 0;
  double position_px = 0;  // NaN: not measured (the sample still moves the servo)
};

struct ResolutionFitOptions {
  int max_step_us = 10;
  int max_dead_band_us = 12;
  int initial_approach = 1;  // the sweep started from below (backlash taken up)
  double min_rms_ratio = 2.5;
  bool Check(std::string* why) const;
};

struct ResolutionFit {
  bool ok = false;                                 // a model was fitted (enough samples and motion)
  bool determined = false;                         // clearly better than every different model
  bool dead_band_determined = false;               // dead_band_min_us == dead_band_max_us
  int dead_band_min_us = 0, dead_band_max_us = 0;  // dead bands that fit equally well
  std::string message;                             // what was found, or why nothing was
  models::ServoResolution resolution;
  double px_per_us = 0;  // signed: image motion per us
  double hysteresis_us = 0;
  double rms_px = 0;            // residual of the best model
  double runner_up_rms_px = 0;  // best model with a different applied sequence (NaN: none)
  std::string runner_up;        // "step 1 us, dead band 2 us, phase 0"
  int num_samples = 0;          // samples with a position
  std::vector<int> applied_us;  // replayed applied pulse per input sample
};

// One servo's fit, as a calibration run keeps it (evaluation/calibration_run.h).
struct ServoResolutionResult {
  int servo = 0;  // models::ServoIndex
  ResolutionFit fit;
};

ResolutionFit FitServoResolution(const std::vector<ResolutionSample>& samples,
                                 const ResolutionFitOptions& options = {});

// "step 5 us (phase 3), dead band 1-5 us" / "step 1 us, dead band 3 us".
std::string DescribeResolution(const ResolutionFit& fit);

}  // namespace owlcal::fitting
