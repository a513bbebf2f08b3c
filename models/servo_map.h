#pragma once
// PWM pulse width -> joint angle for one hobby servo, and back.
//
// params (kNumParams = 5):
//   0 centre_us     pulse width at which the joint angle is zero [us]
//   1 deg_per_us    slope at the centre [deg/us] (nominal 0.113)
//   2 quad_deg      quadratic term at |u - centre| = kNormUs [deg]
//   3 cubic_deg     cubic term at |u - centre| = kNormUs [deg]
//   4 hysteresis_us half-width of the backlash band [us] (>= 0)
// plus a fixed `direction` (+1 or -1) that is never estimated:
//
//   x           = (u_eff - centre_us) / kNormUs
//   angle_deg   = direction * (deg_per_us * (u_eff - centre_us) + quad_deg * x^2 + cubic_deg * x^3)
//   u_eff       = u - approach * hysteresis_us
//
// `approach` is the sign of the last move that reached u: +1 when u was approached from
// below (increasing PWM), -1 from above, 0 when unknown (the middle of the backlash band).
// Angles are SI inside: JointAngle returns radians. The map is monotone wherever
// d angle / du has the sign of `direction`; IsMonotone checks a range.
//
// Usage:
//   double p[ServoMap::kNumParams] = {1545, 0.113, 0, 0, 0};
//   double pan_rad = ServoMap::JointAngle(p, /*direction=*/1, 1600.0, /*approach=*/0);
#include <cmath>

#include <ceres/jet.h>

namespace owlcal::models {

struct ServoMap {
  static constexpr int kNumParams = 5;
  static constexpr double kNormUs = 400.0;
  static constexpr double kNominalDegPerUs = 0.113;

  template <typename T>
  static T JointAngle(const T* params, int direction, double u_us, int approach) {
    const T u_eff = T(u_us) - double(approach) * params[4];
    const T du = u_eff - params[0];
    const T x = du / kNormUs;
    const T deg = params[1] * du + params[2] * x * x + params[3] * x * x * x;
    return double(direction) * deg * (M_PI / 180.0);
  }

  // d angle / d u in rad/us (double only).
  static double Slope(const double* params, int direction, double u_us, int approach) {
    const double du = u_us - double(approach) * params[4] - params[0];
    const double x = du / kNormUs;
    const double d_deg = params[1] + (2 * params[2] * x + 3 * params[3] * x * x) / kNormUs;
    return direction * d_deg * M_PI / 180.0;
  }

  // The pulse width (real-valued) that gives `angle_rad`: Newton from the linear guess.
  // Returns NaN if the map is not invertible there.
  static double PulseWidth(const double* params, int direction, double angle_rad, int approach) {
    double u = params[0] + double(approach) * params[4] + direction * angle_rad * 180.0 / M_PI / params[1];
    for (int it = 0; it < 60; ++it) {
      const double f = JointAngle(params, direction, u, approach) - angle_rad;
      const double s = Slope(params, direction, u, approach);
      if (s == 0.0 || !std::isfinite(s)) return NAN;
      const double step = f / s;
      u -= step;
      if (std::abs(step) < 1e-13 * std::max(1.0, std::abs(u))) break;
    }
    if (std::abs(JointAngle(params, direction, u, approach) - angle_rad) > 1e-11) return NAN;
    return u;
  }

  // True if the map is strictly monotone (in `direction`) over [lo_us, hi_us].
  static bool IsMonotone(const double* params, int direction, double lo_us, double hi_us) {
    for (int i = 0; i <= 200; ++i) {
      const double u = lo_us + (hi_us - lo_us) * i / 200.0;
      if (Slope(params, direction, u, 0) * direction <= 0.0) return false;
    }
    return true;
  }
};

}  // namespace owlcal::models
