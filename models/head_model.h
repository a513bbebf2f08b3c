#pragma once
// A whole head as data: five servo maps, the head geometry and both cameras. Composes
// servo_map.h, head_kinematics.h and camera_model.h for double-precision callers (sim,
// calib, reports). Fitting uses the templated pieces directly.
//
// Usage:
//   HeadModel head = NominalHeadModel(DefaultRobotConfig());
//   JointAngles a = head.Angles({1545, 1530, 1545, 1580, 1530});
//   Eigen::Vector2d px;
//   if (head.Project(kLeftEye, a, Eigen::Vector3d(0, 0, 1.0), &px)) { ... }
#include <array>

#include <Eigen/Core>

#include "models/camera_model.h"
#include "models/head_kinematics.h"
#include "models/robot_config.h"
#include "models/servo_map.h"

namespace owlcal::models {

struct JointAngles {
  double pan_rad[2] = {0, 0};  // [kLeftEye], [kRightEye]
  double tilt_rad[2] = {0, 0};
  double neck_rad = 0;
};

// Which servo drives which joint.
inline constexpr ServoIndex kPanServo[2] = {kLx, kRx};
inline constexpr ServoIndex kTiltServo[2] = {kLy, kRy};

struct HeadModel {
  std::array<std::array<double, ServoMap::kNumParams>, kNumServos> servo_params{};
  std::array<int, kNumServos> directions{};
  HeadGeometry geometry;
  CameraIntrinsics intrinsics[2];

  double ServoAngle(int servo, double pwm_us, int approach = 0) const {
    return ServoMap::JointAngle(servo_params[servo].data(), directions[servo], pwm_us, approach);
  }
  double ServoPulse(int servo, double angle_rad, int approach = 0) const {
    return ServoMap::PulseWidth(servo_params[servo].data(), directions[servo], angle_rad, approach);
  }

  // Joint angles for pulse widths in wire order; approach per servo (+1/-1/0).
  JointAngles Angles(const std::array<double, kNumServos>& pwm_us,
                     const std::array<int, kNumServos>& approach = {}) const {
    JointAngles a;
    for (int e = 0; e < 2; ++e) {
      a.pan_rad[e] = ServoAngle(kPanServo[e], pwm_us[kPanServo[e]], approach[kPanServo[e]]);
      a.tilt_rad[e] = ServoAngle(kTiltServo[e], pwm_us[kTiltServo[e]], approach[kTiltServo[e]]);
    }
    a.neck_rad = ServoAngle(kNeck, pwm_us[kNeck], approach[kNeck]);
    return a;
  }
  JointAngles Angles(const PwmVector& pwm_us) const {
    std::array<double, kNumServos> d;
    for (int i = 0; i < kNumServos; ++i) d[i] = pwm_us[i];
    return Angles(d);
  }

  Eigen::Vector3d PointInCam(Eye eye, const JointAngles& a, const Eigen::Vector3d& x_in_base) const {
    double pose[7];
    geometry.cam_from_eye[eye].ToArray(pose);
    return models::PointInCam<double>(
        pose, geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye], a.neck_rad, x_in_base);
  }

  bool Project(Eye eye, const JointAngles& a, const Eigen::Vector3d& x_in_base, Eigen::Vector2d* pixel) const {
    const Eigen::Vector3d p = PointInCam(eye, a, x_in_base);
    return intrinsics[eye].Project(p.data(), pixel->data());
  }
};

// The nominal head for a robot file: linear maps at the configured centres with the nominal
// scale, design IPD, eyes 30 mm ahead of the neck axis, ideal mounting, f = 585 px.
inline HeadModel NominalHeadModel(const RobotConfig& robot) {
  HeadModel h;
  for (int i = 0; i < kNumServos; ++i) {
    h.servo_params[i] = {double(robot.servos[i].centre_us), robot.servos[i].nominal_deg_per_us, 0, 0, 0};
    h.directions[i] = robot.servos[i].direction;
  }
  h.geometry.centre_in_head[kLeftEye] = Eigen::Vector3d(-robot.ipd_m / 2, 0, 0.03);
  h.geometry.centre_in_head[kRightEye] = Eigen::Vector3d(robot.ipd_m / 2, 0, 0.03);
  for (int e = 0; e < 2; ++e) {
    h.intrinsics[e].width = robot.image_width;
    h.intrinsics[e].height = robot.image_height;
    h.intrinsics[e].params = {585, 585, (robot.image_width - 1) / 2.0, (robot.image_height - 1) / 2.0, 0, 0, 0, 0, 0};
  }
  return h;
}

}  // namespace owlcal::models
