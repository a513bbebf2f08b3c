#pragma once
// The course's incremental proportional fixation loop with latency, and what it implies for
// gain choice (docs/conventions.md, Facts "Control with latency").
//
// Model (per frame k, frame period T = 1 / fps, d frames of delay between a command and the
// image that shows it):
//   y(k+1) = y(k) + K (r - y(k - d)),  y(k) = 0 for k <= 0,  r = 1
// y is the fraction of the step the eye has turned; K the gain as a fraction of the
// measured error applied per frame (theta += K * error). Closed-loop characteristic
// polynomial z^(d+1) - z^d + K: stable for 0 < K < K_crit = 2 sin(pi / (2 (2d + 1))),
// monotone (no overshoot) for K <= K_mono = d^d / (d + 1)^(d + 1).
// Settling is counted in frames with fitting/step_response.h (2 % band, "settles at
// frame k" = the first frame from which all later frames are in the band).
//
// The physical lower bound of a fixation step of A degrees: the servo must slew A degrees,
// the image showing the target must reach the host (latency), and one frame must show the
// result: t_min = A / slew + latency + 1 / fps. A loop that knows the calibrated
// pixel -> us map could jump once and approach it.
#include <optional>
#include <vector>

#include "fitting/step_response.h"

namespace owlcal::fitting {

// y(0 .. num_frames) of the loop above for gain K and delay d >= 0 frames.
std::vector<double> SimulateDelayedPLoop(double gain, int delay_frames, int num_frames);

// Stability and monotonicity limits of the gain for delay d.
double CriticalGain(int delay_frames);
double MonotoneGain(int delay_frames);

struct GainSettling {
  double gain = 0;
  bool stable = false;       // gain in (0, K_crit)
  bool settled = false;      // settled within the simulated frames
  int settling_frames = -1;  // frame index of settling (StepInfo::settling_index)
  double overshoot_pct = 0;
  double settling_time_s = 0;  // settling_frames / fps; NaN when not settled
};

// Simulates every gain (num_frames frames each; 0 = enough frames for the slowest gain to
// settle or 2000) and returns one row per gain, in the order given.
std::vector<GainSettling> SettlingVersusGain(const std::vector<double>& gains,
                                             int delay_frames,
                                             double fps = 30.0,
                                             int num_frames = 0);

// The stable, settled row with the fewest settling frames (ties: the smallest gain);
// nullopt when none settled.
std::optional<GainSettling> FastestStableGain(const std::vector<GainSettling>& rows);

// Evenly spaced gains lo, lo + step, ... <= hi (for a sweep).
std::vector<double> GainGrid(double lo, double hi, double step);

// t_min = step_deg / slew_deg_per_s + latency_s + 1 / fps [s].
double PhysicalLowerBoundS(double step_deg, double slew_deg_per_s, double latency_s, double fps = 30.0);

// What the loop model says about gain choice for one robot's latency.
struct GainStudy {
  int delay_frames = 3;
  double fps = 30;
  std::vector<GainSettling> simulated;  // the delayed P-loop over a gain grid
  double critical_gain = 0, monotone_gain = 0;
  std::optional<GainSettling> fastest;
  // Physical lower bound per amplitude: slew at 400 deg/s + 100 ms (fast) and 300 deg/s +
  // 150 ms (slow) + one frame.
  std::vector<double> amplitudes_deg, lower_bound_fast_s, lower_bound_slow_s;
};

// The gain study for d frames of delay: gain grid 0.005 .. 0.6 in steps of 0.005, the limits
// K_crit and K_mono, the fastest stable gain, and the lower bounds for 2, 5, 10, 15, 20 deg.
GainStudy MakeGainStudy(int delay_frames, double fps = 30.0);

}  // namespace owlcal::fitting
