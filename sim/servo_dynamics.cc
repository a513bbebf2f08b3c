#include "sim/servo_dynamics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace owlcal::sim {

ServoDynamics::ServoDynamics(const ServoTruth& truth, int initial_us, int64_t t0_ns)
    : truth_(truth),
      slew_rad_s_(truth.slew_deg_per_s * M_PI / 180.0),
      stop_lo_(truth.StopLoRad()),
      stop_hi_(truth.StopHiRad()),
      active_us_(initial_us) {
  const double a = CommandedAngle(initial_us, 0);
  segments_.push_back({t0_ns, a, a, a});
}

double ServoDynamics::CommandedAngle(int u_us, int approach) const {
  const auto p = truth_.MapParams();
  const double a = models::ServoMap::JointAngle(p.data(), truth_.direction, double(u_us), approach);
  return std::clamp(a, stop_lo_, stop_hi_);
}

bool ServoDynamics::Command(int u_us, int64_t t_ns) {
  if (t_ns < segments_.back().t0_ns) {
    throw std::invalid_argument("ServoDynamics::Command: time " + std::to_string(t_ns) +
                                " ns is before the last command at " + std::to_string(segments_.back().t0_ns) + " ns");
  }
  const int q = std::max(1, truth_.quantum_us);
  const int u = int(std::lround(double(u_us) / q)) * q;
  if (std::abs(u - active_us_) < truth_.dead_band_us || u == active_us_) return false;
  approach_ = u > active_us_ ? 1 : -1;
  active_us_ = u;
  double r = 0;
  const double y = [&] {
    const Segment& s = segments_.back();
    return SlewLagState(s.r0, s.y0, s.target, slew_rad_s_, truth_.lag_s, (t_ns - s.t0_ns) * 1e-9, &r);
  }();
  if (segments_.back().t0_ns == t_ns) segments_.pop_back();
  segments_.push_back({t_ns, r, y, CommandedAngle(u, approach_)});
  return true;
}

const ServoDynamics::Segment& ServoDynamics::SegmentAt(int64_t t_ns) const {
  // Last segment starting at or before t_ns (the first one if t_ns is older than history).
  auto it = std::upper_bound(
      segments_.begin(), segments_.end(), t_ns, [](int64_t t, const Segment& s) { return t < s.t0_ns; });
  if (it == segments_.begin()) return segments_.front();
  return *(it - 1);
}

double ServoDynamics::AngleAt(int64_t t_ns) const {
  const Segment& s = SegmentAt(t_ns);
  const double dt = std::max<int64_t>(0, t_ns - s.t0_ns) * 1e-9;
  return SlewLagState(s.r0, s.y0, s.target, slew_rad_s_, truth_.lag_s, dt);
}

double ServoDynamics::ReferenceAt(int64_t t_ns) const {
  const Segment& s = SegmentAt(t_ns);
  const double dt = std::max<int64_t>(0, t_ns - s.t0_ns) * 1e-9;
  double r = 0;
  SlewLagState(s.r0, s.y0, s.target, slew_rad_s_, truth_.lag_s, dt, &r);
  return r;
}

void ServoDynamics::ForgetBefore(int64_t t_ns) {
  while (segments_.size() > 1 && segments_[1].t0_ns <= t_ns) segments_.pop_front();
}

}  // namespace owlcal::sim
