#pragma once
// Head kinematics of the Owl: PWM vector + world point -> pixel in each eye.
//
// Frames (all x right, y down, z forward, as the camera frame; SI units):
//   base  fixed to the robot's body; origin on the neck axis at eye height.
//   head  turns with the neck: base_from_head = RotY(neck_rad). Positive neck_rad turns the
//         head to the robot's right.
//   eye   each eye's pan/tilt joint: origin at the eye's rotation centre; the pan joint is the
//         outer one (turns about head y), tilt the inner one (about the panned x):
//           head_from_eye = Translation(centre_in_head) * RotY(pan_rad) * RotX(tilt_rad)
//         pan_rad > 0 looks right, tilt_rad > 0 looks up.
//   cam   the optical frame of the camera module, mounted on the eye with a small rotation
//         and an offset from the rotation centre: cam_from_eye (a 7-block pose).
// So   x_in_cam = cam_from_eye * eye_from_head(pan, tilt) * head_from_base(neck) * x_in_base.
// IPD is |right_centre_in_head - left_centre_in_head|; with zero mounting error and the
// centre pose, the eyes look along +z and a point at depth Z ahead shows horizontal
// disparity x_left - x_right = f * IPD / Z.
//
// Angles come from the servo maps (models/servo_map.h): pan = Rx/Lx, tilt = Ry/Ly, neck.
#include <Eigen/Core>

#include "models/rigid3.h"

namespace owlcal::models {

enum Eye { kLeftEye = 0, kRightEye = 1 };
inline constexpr const char* kEyeNames[2] = {"left", "right"};

template <typename T>
Rigid3<T> HeadFromBase(const T& neck_rad) {
  return Rigid3<T>(RotY(neck_rad), Eigen::Matrix<T, 3, 1>::Zero()).Inverse();
}

// centre_in_head: 3 values [m].
template <typename T>
Rigid3<T> HeadFromEye(const T* centre_in_head, const T& pan_rad, const T& tilt_rad) {
  return Rigid3<T>(RotY(pan_rad) * RotX(tilt_rad),
                   Eigen::Matrix<T, 3, 1>(centre_in_head[0], centre_in_head[1], centre_in_head[2]));
}

// x_in_cam for a base-frame point. cam_from_eye: 7-block pose.
template <typename T>
Eigen::Matrix<T, 3, 1> PointInCam(const T* cam_from_eye,
                                  const T* centre_in_head,
                                  const T& pan_rad,
                                  const T& tilt_rad,
                                  const T& neck_rad,
                                  const Eigen::Matrix<T, 3, 1>& x_in_base) {
  const Rigid3<T> cam_from_base =
      Rigid3<T>::Map(cam_from_eye) * HeadFromEye(centre_in_head, pan_rad, tilt_rad).Inverse() * HeadFromBase(neck_rad);
  return cam_from_base * x_in_base;
}

// The geometry of one head as data (truth in sim, estimate in fitting).
struct HeadGeometry {
  Eigen::Vector3d centre_in_head[2] = {Eigen::Vector3d(-0.0325, 0, 0.03), Eigen::Vector3d(0.0325, 0, 0.03)};
  Rigid3d cam_from_eye[2];
  double Ipd() const { return (centre_in_head[kRightEye] - centre_in_head[kLeftEye]).norm(); }
};

}  // namespace owlcal::models
