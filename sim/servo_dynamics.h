#pragma once
// Truth dynamics of one servo (sim/robot_truth.h, ServoTruth), exact in continuous time.
//
// A command u [us] (already clamped by the course server) at time t_ns is
//   1. quantised to a multiple of quantum_us,
//   2. ignored if it differs from the last accepted pulse by less than dead_band_us,
//   3. turned into a commanded joint angle by the truth models::ServoMap with approach =
//      sign of the change (backlash), clamped to the physical end-stop angles.
// The joint then moves: a reference r slews at slew_deg_per_s towards the commanded angle,
// and the joint angle y follows it with a first-order lag, lag_s * dy/dt = r - y. Between
// commands this has a closed form (SlewLagState), so AngleAt(t) is exact at any time, past
// ones included (the stream renders frames exposed before the current time).
//
// Usage:
//   ServoDynamics s(truth.servos[kRx], /*initial_us=*/1545, /*t0_ns=*/0);
//   s.Command(1600, now_ns);
//   double pan_rad = s.AngleAt(now_ns + 50'000'000);
#include <cstdint>
#include <deque>

#include "models/slew_lag.h"
#include "sim/robot_truth.h"

namespace owlcal::sim {

// Closed-form slew + first-order-lag response (models/slew_lag.h): slew in rad/s here.
using models::SlewLagState;

class ServoDynamics {
 public:
  ServoDynamics(const ServoTruth& truth, int initial_us, int64_t t0_ns);

  // Applies a pulse-width command at t_ns (t_ns must not go back in time). Returns true if
  // the servo accepted it (outside the dead band).
  bool Command(int u_us, int64_t t_ns);

  // Joint angle [rad] at time t_ns (any time after the oldest kept history).
  double AngleAt(int64_t t_ns) const;
  // Reference (slewing) angle at t_ns [rad].
  double ReferenceAt(int64_t t_ns) const;
  // The commanded angle the servo is heading for [rad], and the last accepted pulse.
  double TargetRad() const { return segments_.back().target; }
  int ActivePulseUs() const { return active_us_; }
  int Approach() const { return approach_; }
  // Forgets segments that ended before t_ns (keeps the one active at t_ns).
  void ForgetBefore(int64_t t_ns);
  const ServoTruth& truth() const { return truth_; }

 private:
  struct Segment {
    int64_t t0_ns;
    double r0, y0, target;
  };
  const Segment& SegmentAt(int64_t t_ns) const;
  double CommandedAngle(int u_us, int approach) const;

  ServoTruth truth_;
  double slew_rad_s_;
  double stop_lo_, stop_hi_;
  int active_us_;
  int approach_ = 0;
  std::deque<Segment> segments_;
};

}  // namespace owlcal::sim
