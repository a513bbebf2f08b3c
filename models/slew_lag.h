#pragma once
// A servo's joint motion after a command, exact in continuous time: a reference r slews at a
// constant rate towards the commanded angle, and the joint angle y follows it with a
// first-order lag, lag * dy/dt = r - y. The virtual Owl's truth (sim/servo_dynamics.h) and
// owlcal's settling model (fitting/settling_model.h) both use it.
//
// Units: angles in any unit, slew in that unit per second (> 0), lag and dt in seconds (>= 0).
//
// Usage:
//   double r = 0;
//   double y = SlewLagState(/*r0=*/0, /*y0=*/0, /*target=*/0.17, /*slew=*/6.6, /*lag=*/0.025, 0.05, &r);
#include <algorithm>
#include <cmath>
#include <vector>

namespace owlcal::models {

// y after dt seconds from state (r0, y0) heading for `target`; *r_out gets r.
inline double SlewLagState(
    double r0, double y0, double target, double slew, double lag, double dt, double* r_out = nullptr) {
  const double diff = target - r0;
  const double s = diff > 0 ? slew : (diff < 0 ? -slew : 0.0);
  const double t_ramp = s == 0 ? 0.0 : std::abs(diff) / slew;
  // Phase 1 (0 <= tau <= t_ramp): r = r0 + s tau, and with lag T
  //   y = r0 + s (tau - T) + (y0 - r0 + s T) exp(-tau / T).
  auto ramp = [&](double tau) {
    if (lag <= 0) return r0 + s * tau;
    return r0 + s * (tau - lag) + (y0 - r0 + s * lag) * std::exp(-tau / lag);
  };
  if (dt <= t_ramp) {
    if (r_out) *r_out = r0 + s * dt;
    return ramp(dt);
  }
  // Phase 2: r = target, y relaxes exponentially from y(t_ramp).
  if (r_out) *r_out = target;
  const double y1 = ramp(t_ramp);
  if (lag <= 0) return target;
  return target + (y1 - target) * std::exp(-(dt - t_ramp) / lag);
}

// A joint's trajectory under a sequence of commands (times increasing), evaluated at any
// time after the first: SlewLagState between commands. Units as above; times in seconds.
class SlewLagTrajectory {
 public:
  SlewLagTrajectory(double slew, double lag, double t0, double at_rest)
      : slew_(slew), lag_(lag), segs_{{t0, at_rest, at_rest, at_rest}} {}

  // From time t on, head for `target` (t must not precede the last command).
  void Command(double t, double target) {
    const Seg& s = segs_.back();
    double r = 0;
    const double y = SlewLagState(s.r0, s.y0, s.target, slew_, lag_, std::max(0.0, t - s.t0), &r);
    segs_.push_back({t, r, y, target});
  }
  double At(double t) const {
    auto it = std::upper_bound(segs_.begin(), segs_.end(), t, [](double x, const Seg& s) { return x < s.t0; });
    const Seg& s = it == segs_.begin() ? segs_.front() : *(it - 1);
    return SlewLagState(s.r0, s.y0, s.target, slew_, lag_, std::max(0.0, t - s.t0));
  }

 private:
  struct Seg {
    double t0, r0, y0, target;
  };
  double slew_, lag_;
  std::vector<Seg> segs_;
};

}  // namespace owlcal::models
