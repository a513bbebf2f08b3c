#pragma once
// The calibrated saccade controller against the physical bound and the course's P loop.
//
// Physical bound of a fixation step of A degrees (fitting/ploop_analysis.h PhysicalLowerBoundS):
//   t_min = A / slew + exposure delay + 1 / fps
// the servo must turn A degrees at its slew rate, and a frame exposed after that must reach the
// host (the stream's exposure-to-arrival delay; docs/conventions.md, Facts "Control with latency").
// The slew and delay are the ones fitted from the step frames (fitting/servo_motion_fit.h).
//
// Settling times are the 2 % settling of fitting/step_response.h (band as in
// fitting/loop_model.h), measured from the first frame of the trial, as for the P-loop trials;
// medians over the trials with status ok that settled. The ratio to the bound and the speed-up
// over the P loop at the reference gain (same amplitude) are what the report prints.
#include <string>
#include <vector>

#include "fitting/step_response.h"

namespace owlcal::evaluation {

struct SaccadeEvaluation {
  double amplitude_deg = 10;
  double slew_deg_per_s = 0, exposure_delay_s = 0, fps = 30;
  double bound_s = 0;
  int num_trials = 0, num_ok = 0, num_settled = 0;
  double median_s = 0, lo_s = 0, hi_s = 0;  // NaN: no trial settled
  double ratio_to_bound = 0;                // median / bound
  double ploop_gain = 0.1;
  int ploop_trials = 0, ploop_settled = 0;
  double ploop_median_s = 0;       // NaN: none settled (then speedup_vs_ploop is a lower bound)
  double speedup_vs_ploop = 0;     // P-loop median / saccade median
  std::vector<std::string> notes;  // failed trials named
};

// traces: every step trace of the run (controller "saccade" and "p-loop"); only those of
// `amplitude_deg` (either sign) count.
SaccadeEvaluation EvaluateSaccades(const std::vector<fitting::StepTrace>& traces,
                                   double amplitude_deg,
                                   double slew_deg_per_s,
                                   double exposure_delay_s,
                                   double fps,
                                   double ploop_gain = 0.1);

}  // namespace owlcal::evaluation
