#include "fitting/pixel_pwm_map.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <Eigen/Dense>

namespace owlcal::fitting {
namespace {

constexpr double kInfinity_m = 1e4;  // "infinity": 30 mm of parallax is 3 microradians here

models::Rigid3d CamFromBase(const models::HeadModel& head, models::Eye eye, const models::JointAngles& a) {
  return head.geometry.cam_from_eye[eye] *
         models::HeadFromEye(head.geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye]).Inverse() *
         models::HeadFromBase(a.neck_rad);
}

std::array<double, models::kNumServos> WithEye(std::array<double, models::kNumServos> pwm,
                                               models::Eye eye,
                                               double pan_us,
                                               double tilt_us) {
  pwm[models::kPanServo[eye]] = pan_us;
  pwm[models::kTiltServo[eye]] = tilt_us;
  return pwm;
}

bool ProjectAt(const models::HeadModel& head,
               models::Eye eye,
               const std::array<double, models::kNumServos>& pwm,
               const std::array<int, models::kNumServos>& approach,
               const Eigen::Vector3d& x_in_base,
               Eigen::Vector2d* px) {
  return head.Project(eye, head.Angles(pwm, approach), x_in_base, px);
}

// The backlash side a move from `from` to `to` ends on, per servo (0: not moved).
std::array<int, models::kNumServos> ApproachOf(const std::array<double, models::kNumServos>& from,
                                               const std::array<double, models::kNumServos>& to) {
  std::array<int, models::kNumServos> a{};
  for (int i = 0; i < models::kNumServos; ++i) a[i] = to[i] > from[i] ? 1 : (to[i] < from[i] ? -1 : 0);
  return a;
}

}  // namespace

bool CentringOptions::Check(std::string* why) const {
  if (!(distance_m >= 0) || max_iterations < 1 || !(tolerance_px > 0)) {
    if (why) *why = "CentringOptions: distance_m >= 0, max_iterations >= 1 and tolerance_px > 0";
    return false;
  }
  return true;
}

Centring PulsesToCentre(const models::HeadModel& head,
                        const models::RobotConfig& robot,
                        models::Eye eye,
                        const Eigen::Vector2d& pixel,
                        const std::array<double, models::kNumServos>& pwm_us,
                        const CentringOptions& o) {
  Centring c;
  std::string why;
  if (!o.Check(&why)) {
    c.message = why;
    return c;
  }
  const models::CameraIntrinsics& cam = head.intrinsics[eye];
  const Eigen::Vector2d centre(cam.params[2], cam.params[3]);
  double q[2] = {pixel.x(), pixel.y()}, r[3];
  if (!cam.Unproject(q, r)) {
    c.message = "pixel (" + std::to_string(pixel.x()) + ", " + std::to_string(pixel.y()) + ") cannot be unprojected";
    return c;
  }
  // The target in the base frame (fixed while the eye turns).
  const models::Rigid3d base_from_cam = CamFromBase(head, eye, head.Angles(pwm_us)).Inverse();
  const Eigen::Vector3d ray = Eigen::Vector3d(r[0], r[1], 1.0).normalized();
  const Eigen::Vector3d x_in_base = base_from_cam * (ray * (o.distance_m > 0 ? o.distance_m : kInfinity_m));
  // Newton on (pan, tilt) [us]: the target's pixel minus the centre, each servo on a fixed
  // backlash side: first the middle of the band (0), then the side the move ends on.
  const models::ServoIndex ps = models::kPanServo[eye], ts = models::kTiltServo[eye];
  std::array<int, models::kNumServos> approach{};
  auto residual = [&](const Eigen::Vector2d& v, Eigen::Vector2d* f) {
    Eigen::Vector2d p;
    if (!ProjectAt(head, eye, WithEye(pwm_us, eye, v.x(), v.y()), approach, x_in_base, &p)) return false;
    *f = p - centre;
    return true;
  };
  Eigen::Vector2d u(pwm_us[ps], pwm_us[ts]), f;
  for (int stage = 0; stage < 2; ++stage) {
    if (stage == 1) {
      approach[ps] = u.x() > pwm_us[ps] ? 1 : (u.x() < pwm_us[ps] ? -1 : 0);
      approach[ts] = u.y() > pwm_us[ts] ? 1 : (u.y() < pwm_us[ts] ? -1 : 0);
    }
    if (!residual(u, &f)) {
      c.message = "the target is behind the camera";
      return c;
    }
    int it = 0;
    for (; it < o.max_iterations && f.norm() > o.tolerance_px; ++it) {
      Eigen::Matrix2d J;
      for (int k = 0; k < 2; ++k) {
        Eigen::Vector2d d = Eigen::Vector2d::Zero(), fp, fm;
        d[k] = 0.5;
        if (!residual(u + d, &fp) || !residual(u - d, &fm)) {
          c.message = "the target leaves the model's view while solving";
          return c;
        }
        J.col(k) = fp - fm;  // per us (steps of +-0.5 us)
      }
      if (std::abs(J.determinant()) < 1e-12) {
        c.message = "pan and tilt do not move the target independently here";
        return c;
      }
      Eigen::Vector2d step = -J.partialPivLu().solve(f);
      if (step.norm() > 200) step *= 200 / step.norm();  // damped: at most 200 us per iteration
      Eigen::Vector2d un = u + step, fn;
      double lambda = 1;
      while (!residual(un, &fn) || fn.norm() > f.norm()) {
        lambda /= 2;
        if (lambda < 1e-3) break;
        un = u + lambda * step;
      }
      if (lambda < 1e-3) break;
      u = un;
      f = fn;
    }
    c.iterations += it;
    if (!(f.norm() <= std::max(o.tolerance_px, 1e-2))) {
      c.message = "no convergence: " + std::to_string(f.norm()) + " px from the centre after " + std::to_string(it) +
                  " iterations";
      return c;
    }
  }
  // A servo whose solution lies on the other side of its current pulse width than the side it
  // was solved for needs less than its backlash: it cannot get there in that direction, so it
  // stays (the target stays within half a band of the centre on that axis).
  if ((approach[ps] > 0 && u.x() < pwm_us[ps]) || (approach[ps] < 0 && u.x() > pwm_us[ps])) {
    u.x() = pwm_us[ps];
    approach[ps] = 0;
  }
  if ((approach[ts] > 0 && u.y() < pwm_us[ts]) || (approach[ts] < 0 && u.y() > pwm_us[ts])) {
    u.y() = pwm_us[ts];
    approach[ts] = 0;
  }
  c.pan_us = u.x();
  c.tilt_us = u.y();
  c.pan_cmd_us = robot.servos[ps].Clamp(static_cast<int>(std::lround(u.x())));
  c.tilt_cmd_us = robot.servos[ts].Clamp(static_cast<int>(std::lround(u.y())));
  c.clamped = c.pan_cmd_us != std::lround(u.x()) || c.tilt_cmd_us != std::lround(u.y());
  Eigen::Vector2d fr;
  c.predicted_error_px = residual(Eigen::Vector2d(c.pan_cmd_us, c.tilt_cmd_us), &fr) ? fr.norm() : NAN;
  c.ok = true;
  return c;
}

std::optional<Eigen::Vector2d> PixelCentredBy(const models::HeadModel& head,
                                              models::Eye eye,
                                              double pan_us,
                                              double tilt_us,
                                              const std::array<double, models::kNumServos>& pwm_us,
                                              double distance_m) {
  // The point on the new optical axis, then where the eye sees it now.
  const auto moved = WithEye(pwm_us, eye, pan_us, tilt_us);
  const models::Rigid3d base_from_cam = CamFromBase(head, eye, head.Angles(moved, ApproachOf(pwm_us, moved))).Inverse();
  const Eigen::Vector3d x_in_base = base_from_cam * Eigen::Vector3d(0, 0, distance_m > 0 ? distance_m : kInfinity_m);
  // The axis of the pinhole: the principal point's ray (distortion is zero there).
  Eigen::Vector2d px;
  if (!ProjectAt(head, eye, pwm_us, {}, x_in_base, &px)) return std::nullopt;
  return px;
}

PixelPwmGrid MakePixelPwmGrid(const models::HeadModel& head,
                              const models::RobotConfig& robot,
                              int step_px,
                              double distance_m) {
  PixelPwmGrid g;
  g.distance_m = distance_m;
  g.centre_pwm = robot.Centre();
  std::array<double, models::kNumServos> centre{};
  for (int i = 0; i < models::kNumServos; ++i) centre[i] = g.centre_pwm[i];
  const int W = robot.image_width, H = robot.image_height, step = std::max(1, step_px);
  for (int x = 0; x < W - 1; x += step) g.xs.push_back(x);
  g.xs.push_back(W - 1);
  for (int y = 0; y < H - 1; y += step) g.ys.push_back(y);
  g.ys.push_back(H - 1);
  g.cols = static_cast<int>(g.xs.size());
  g.rows = static_cast<int>(g.ys.size());
  CentringOptions o;
  o.distance_m = distance_m;
  for (int e = 0; e < 2; ++e) {
    const models::Eye eye = static_cast<models::Eye>(e);
    for (double y : g.ys)
      for (double x : g.xs) {
        PixelPwmRow r;
        r.eye = e;
        r.x_px = x;
        r.y_px = y;
        const Centring c = PulsesToCentre(head, robot, eye, {x, y}, centre, o);
        r.ok = c.ok;
        r.clamped = c.clamped;
        if (c.ok) {
          r.pan_us = c.pan_us;
          r.tilt_us = c.tilt_us;
          r.delta_pan_us = c.pan_us - centre[models::kPanServo[e]];
          r.delta_tilt_us = c.tilt_us - centre[models::kTiltServo[e]];
        }
        g.rows_data.push_back(r);
      }
  }
  return g;
}

std::string PixelPwmGridCsv(const PixelPwmGrid& g) {
  std::ostringstream s;
  s.precision(8);
  s << "# pixel -> PWM map (owlcal, fitting/pixel_pwm_map.h): the eye's pan/tilt pulse widths [us] that bring what it "
       "sees at (x_px, y_px) to its principal point, head at the centre pose ";
  for (int i = 0; i < models::kNumServos; ++i) s << (i ? " " : "") << g.centre_pwm[i];
  s << " (Rx Ry Lx Ly Neck); target "
    << (g.distance_m > 0 ? "at " + std::to_string(g.distance_m) + " m" : std::string("at infinity"))
    << "; pan is Lx/Rx, tilt Ly/Ry; clamped = 1: outside the robot's limits (the command is clamped)\n";
  s << "eye,x_px,y_px,ok,clamped,pan_us,tilt_us,delta_pan_us,delta_tilt_us\n";
  for (const auto& r : g.rows_data)
    s << models::kEyeNames[r.eye] << "," << r.x_px << "," << r.y_px << "," << r.ok << "," << r.clamped << ","
      << r.pan_us << "," << r.tilt_us << "," << r.delta_pan_us << "," << r.delta_tilt_us << "\n";
  return s.str();
}

}  // namespace owlcal::fitting
