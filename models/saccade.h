#pragma once
// A calibrated saccade: where to send the eye so that a target seen at a pixel ends up at the
// image centre, computed from the fitted head (servo maps, eye centres, camera mounting and
// intrinsics: models/head_model.h), and how to shape the command so that the servo's slew and
// lag (models/slew_lag.h) bring the joint there fastest.
//
// Aim: the target is the base-frame point at `range_m` along the ray through its pixel (the
// camera is ~15 mm ahead of the eye's rotation centre, so the range matters a little: 0.15 deg
// for a 10 deg turn at 1 m). SaccadePulses finds the pan (and tilt) pulses that project that
// point onto the principal point (Newton on the joint angles, then the inverse servo maps with
// the approach of the move, so backlash is accounted for).
//
// Shaping (in pulse units): a plain step makes the joint lag the slewing reference by up to
// slew * lag; commanding `overdrive_us` beyond the target first and the target itself
// `switch_s` later makes the reference turn back early so that the joint arrives at the target
// sooner. ShapeSaccade searches the overdrive and switch time that minimise the time after
// which the joint stays within `band_us` of the target (the plain step is a candidate:
// overdrive 0), for a joint at rest.
//
// Usage:
//   auto p = SaccadePulses(head, kRightEye, pwm, approach, pixel, 1.0, true, false);
//   SaccadeShape s = ShapeSaccade(*p - pwm[kRx], slew_us_per_s, lag_s, 1.8);
#include <array>
#include <cmath>
#include <optional>

#include <Eigen/Core>

#include "models/head_model.h"
#include "models/slew_lag.h"

namespace owlcal::models {

// The base-frame point at range_m along the ray through `pixel` of `eye`, with the head at
// joint angles `a`; nullopt when the pixel cannot be unprojected.
inline std::optional<Eigen::Vector3d> PointAtPixel(
    const HeadModel& head, Eye eye, const JointAngles& a, const Eigen::Vector2d& pixel, double range_m) {
  Eigen::Vector3d ray;
  if (!head.intrinsics[eye].Unproject(pixel.data(), ray.data())) return std::nullopt;
  const Rigid3d cam_from_base =
      head.geometry.cam_from_eye[eye] *
      HeadFromEye(head.geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye]).Inverse() *
      HeadFromBase(a.neck_rad);
  const Rigid3d base_from_cam = cam_from_base.Inverse();
  return Eigen::Vector3d(base_from_cam * (ray.normalized() * range_m));
}

// Pulses [pan, tilt] (real-valued) of `eye` that centre x_in_base, moving only the axes asked
// for (the others keep `a`'s angles). `approach` is the approach each servo will have after the
// move (+1 from below, -1 from above). The point goes to `goal_px` (default: the principal
// point; a controller that measures offsets from the image centre passes that). nullopt when the
// point cannot be centred.
inline std::optional<std::array<double, 2>> SaccadePulses(
    const HeadModel& head,
    Eye eye,
    JointAngles a,
    const Eigen::Vector3d& x_in_base,
    bool pan,
    bool tilt,
    const std::array<int, 2>& approach,
    const std::optional<Eigen::Vector2d>& goal_px = std::nullopt) {
  const double cx = goal_px ? goal_px->x() : head.intrinsics[eye].params[2];
  const double cy = goal_px ? goal_px->y() : head.intrinsics[eye].params[3];
  for (int it = 0; it < 30; ++it) {
    Eigen::Vector2d p0;
    if (!head.Project(eye, a, x_in_base, &p0)) return std::nullopt;
    const Eigen::Vector2d r = p0 - Eigen::Vector2d(cx, cy);
    if ((pan ? std::abs(r.x()) : 0.0) + (tilt ? std::abs(r.y()) : 0.0) < 1e-9) break;
    Eigen::Matrix2d J;
    for (int k = 0; k < 2; ++k) {
      JointAngles b = a;
      (k == 0 ? b.pan_rad[eye] : b.tilt_rad[eye]) += 1e-6;
      Eigen::Vector2d p1;
      if (!head.Project(eye, b, x_in_base, &p1)) return std::nullopt;
      J.col(k) = (p1 - p0) / 1e-6;
    }
    if (pan && tilt) {
      const Eigen::Vector2d step = J.colPivHouseholderQr().solve(r);
      a.pan_rad[eye] -= step[0];
      a.tilt_rad[eye] -= step[1];
    } else if (pan) {
      if (std::abs(J(0, 0)) < 1e-12) return std::nullopt;
      a.pan_rad[eye] -= r.x() / J(0, 0);
    } else {
      if (std::abs(J(1, 1)) < 1e-12) return std::nullopt;
      a.tilt_rad[eye] -= r.y() / J(1, 1);
    }
  }
  const double u_pan = head.ServoPulse(kPanServo[eye], a.pan_rad[eye], approach[0]);
  const double u_tilt = head.ServoPulse(kTiltServo[eye], a.tilt_rad[eye], approach[1]);
  if (!std::isfinite(u_pan) || !std::isfinite(u_tilt)) return std::nullopt;
  return std::array<double, 2>{u_pan, u_tilt};
}

struct SaccadeShape {
  double overdrive_us = 0;  // beyond the target, in the direction of the move (>= 0)
  double switch_s = 0;      // when to command the target itself (0: a plain step)
  double settle_s = 0;      // predicted time after the first command to stay within the band
};

// The fastest shaped step of amplitude_us (signed) for a joint at rest. band_us > 0.
inline SaccadeShape ShapeSaccade(
    double amplitude_us, double slew_us_per_s, double lag_s, double band_us, double max_overdrive_us = 200) {
  const double a = std::abs(amplitude_us);
  auto settle = [&](double b, double t1) {
    // Last time |y - a| > band, sampled every 0.5 ms over 0.5 s.
    double last = 0;
    double r1 = 0;
    const double y1 = SlewLagState(0, 0, a + b, slew_us_per_s, lag_s, t1, &r1);
    for (int i = 1; i <= 1000; ++i) {
      const double t = i * 0.0005;
      const double y = t < t1 ? SlewLagState(0, 0, a + b, slew_us_per_s, lag_s, t)
                              : SlewLagState(r1, y1, a, slew_us_per_s, lag_s, t - t1);
      if (std::abs(y - a) > band_us) last = t;
    }
    return last;
  };
  SaccadeShape best{0, 0, settle(0, 0)};
  if (!(a > band_us) || !(slew_us_per_s > 0) || !(lag_s > 0)) return best;
  const double tmax = a / slew_us_per_s + 4 * lag_s;
  for (int i = 1; i <= 20; ++i) {
    const double b = std::min(max_overdrive_us, a) * i / 20.0;
    for (int j = 1; j <= 40; ++j) {
      const double t1 = tmax * j / 40.0;
      const double s = settle(b, t1);
      if (s < best.settle_s) best = {b, t1, s};
    }
  }
  // Refine around the best.
  const SaccadeShape coarse = best;
  for (int i = -5; i <= 5; ++i)
    for (int j = -5; j <= 5; ++j) {
      const double b = coarse.overdrive_us + i * std::min(max_overdrive_us, a) / 100.0;
      const double t1 = coarse.switch_s + j * tmax / 200.0;
      if (b < 0 || t1 < 0) continue;
      const double s = settle(b, t1);
      if (s < best.settle_s) best = {b, t1, s};
    }
  return best;
}

}  // namespace owlcal::models
