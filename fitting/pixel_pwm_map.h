#pragma once
// The pixel -> PWM map the course notes ask for ("calibrate servo to cameras ... give a map"):
// for any pixel of either eye, the pan and tilt pulse widths that bring what
// the eye sees there to the image centre, and the inverse.
//
// "Centre" is the eye's principal point (cx, cy): a target there lies on the optical axis. The
// target is what the eye sees at `pixel` with the head at `pwm_us`, `distance_m` from the camera
// along that pixel's ray (0 = at infinity, a direction: right for anything beyond a few metres;
// nearer, the camera's offset from the eye's rotation centre shifts the answer by up to a few
// pixels at 0.3 m). The pan/tilt pulse widths are solved with Newton's method on the head model
// (models/head_model.h; each servo on the backlash side the move ends on: a move up ends on the
// lower side of the band; the head at `pwm_us` in the middle of its bands), then rounded to whole
// microseconds and clamped to the robot's limits (a servo is never commanded outside them):
// `clamped` says when the target cannot be centred within them. The other eye and the neck stay
// where they are.
//
// Usage:
//   const Centring c = PulsesToCentre(head, robot, models::kLeftEye, {500, 120}, pwm_now);
//   if (c.ok && !c.clamped) { pwm[kLx] = c.pan_cmd_us; pwm[kLy] = c.tilt_cmd_us; }
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct CentringOptions {
  double distance_m = 0;  // of the target from the camera; 0 = infinity
  int max_iterations = 20;
  double tolerance_px = 1e-3;
  bool Check(std::string* why) const;
};

struct Centring {
  bool ok = false;
  std::string message;                  // why not (ray not projectable, no convergence)
  double pan_us = 0, tilt_us = 0;       // exact solution (may lie outside the limits)
  int pan_cmd_us = 0, tilt_cmd_us = 0;  // rounded and clamped to the limits: what to send
  bool clamped = false;                 // the exact solution is outside a limit
  double predicted_error_px = 0;        // where the model puts the target after the rounded command, from the centre
  int iterations = 0;
};

// The eye's pan and tilt pulse widths that centre what `eye` sees at `pixel` with the head at
// `pwm_us` (wire order).
Centring PulsesToCentre(const models::HeadModel& head,
                        const models::RobotConfig& robot,
                        models::Eye eye,
                        const Eigen::Vector2d& pixel,
                        const std::array<double, models::kNumServos>& pwm_us,
                        const CentringOptions& options = {});

// The inverse: the pixel (head at `pwm_us`) of the target that `eye`'s pan/tilt pulse widths
// `pan_us`, `tilt_us` would centre; nullopt when it is behind the camera or outside the model.
std::optional<Eigen::Vector2d> PixelCentredBy(const models::HeadModel& head,
                                              models::Eye eye,
                                              double pan_us,
                                              double tilt_us,
                                              const std::array<double, models::kNumServos>& pwm_us,
                                              double distance_m = 0);

// The map as a grid over both images at the centre pose: every `step_px` pixels (and the last
// row/column), the pulse widths that centre that pixel and their change from the centre pose.
struct PixelPwmRow {
  int eye = 0;
  double x_px = 0, y_px = 0;
  bool ok = false, clamped = false;
  double pan_us = 0, tilt_us = 0;              // exact
  double delta_pan_us = 0, delta_tilt_us = 0;  // from the centre pose's pulse widths
};
struct PixelPwmGrid {
  int cols = 0, rows = 0;  // per eye
  std::vector<double> xs, ys;
  std::vector<PixelPwmRow> rows_data;  // eye-major, then row-major
  double distance_m = 0;
  models::PwmVector centre_pwm{};
};
PixelPwmGrid MakePixelPwmGrid(const models::HeadModel& head,
                              const models::RobotConfig& robot,
                              int step_px = 40,
                              double distance_m = 0);
// eye,x_px,y_px,ok,clamped,pan_us,tilt_us,delta_pan_us,delta_tilt_us (with a comment header).
std::string PixelPwmGridCsv(const PixelPwmGrid& grid);

}  // namespace owlcal::fitting
