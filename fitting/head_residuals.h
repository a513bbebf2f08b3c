#pragma once
// Residual of the head problem: all corners of one calib::View (one eye,
// one frame, one board) against the head model, whitened by the corner sigma (residuals are
// whitened so the covariance is in physical units; one cost function per view so the chain
// cam_from_target is built once per view).
//
// Parameter blocks, in this order (all Euclidean except the board pose):
//   pan    models::ServoMap params of the eye's pan servo (Lx or Rx)     [5]
//   tilt   models::ServoMap params of the eye's tilt servo (Ly or Ry)    [5]
//   neck   models::ServoMap params of the neck servo                     [5]
//   mount  the camera mounting of this eye, see MountParams below        [5]
//   centres both eye rotation centres in the head frame, see below       [5]
//   base_from_target  7-block [qx qy qz qw tx ty tz] (m)                 [7]
//   camera  models::OpenCvCamera<N> params fx fy cx cy dist...           [4 + N]
//   warp    the board's bow, fitting/board_warp.h [2] (m); held at zero for a flat board
// Residuals: 2 per corner, (projected - measured) / sigma_px, x then y.
//
// MountParams (kMountParams = 5): roll_rad, yaw_rad, tx_m, ty_m, tz_m:
//   cam_from_eye = [RotZ(roll) * RotY(yaw), t]   (x_in_cam = R x_in_eye + t)
// The mount's pitch (a final RotX) is not a parameter: R_mount * RotX(-tilt) makes it exactly
// a constant offset of the tilt angle, which the tilt servo's centre absorbs (gauge, see
// fitting/head_fit.h). Yaw is NOT such a gauge: RotY(yaw) * RotX(-tilt) equals a pan offset
// yaw*cos(tilt) plus an image roll yaw*sin(tilt), so tilting the eye observes it.
//
// CentresParams (kCentresParams = 5): left x, y, z, right x, y [m], with right z = left z:
//   the head's forward (z) axis is perpendicular to the line through the eye centres
//   (the head frame's yaw gauge, see fitting/head_fit.h).
//
// Optional per-corner Huber robustification (huber_k > 0, in sigma units): the 2-vector e of
// a corner is scaled by sqrt(rho(|e|^2) / |e|^2) so its squared norm is Huber's rho; with
// huber_k = 0 the residual is the plain whitened error (used for the final solve and the
// covariance).
#include <cmath>
#include <vector>

#include <ceres/jet.h>
#include <Eigen/Core>
#include <Eigen/Geometry>

#include "fitting/board_warp.h"
#include "models/head_kinematics.h"
#include "models/rigid3.h"
#include "models/servo_map.h"

namespace owlcal::fitting {

inline constexpr int kMountParams = 5;
inline constexpr int kCentresParams = 5;

// cam_from_eye of a mount block [roll, yaw, tx, ty, tz].
template <typename T>
models::Rigid3<T> CamFromEyeOfMount(const T* mount) {
  using ceres::cos;
  using ceres::sin;
  using std::cos;
  using std::sin;
  const Eigen::Quaternion<T> rz(cos(mount[0] / T(2)), T(0), T(0), sin(mount[0] / T(2)));
  return models::Rigid3<T>(rz * models::RotY(mount[1]), Eigen::Matrix<T, 3, 1>(mount[2], mount[3], mount[4]));
}

// Eye centre (3 values) of `eye` from a centres block.
template <typename T>
void EyeCentreOfCentres(const T* centres, int eye, T* centre) {
  if (eye == models::kLeftEye) {
    centre[0] = centres[0];
    centre[1] = centres[1];
  } else {
    centre[0] = centres[3];
    centre[1] = centres[4];
  }
  centre[2] = centres[2];
}

// The servo data of one view needed by the residual.
struct HeadViewCommand {
  int eye = models::kLeftEye;
  double pan_us = 0, tilt_us = 0, neck_us = 0;
  int pan_direction = 1, tilt_direction = 1, neck_direction = 1;
  int pan_approach = 0, tilt_approach = 0, neck_approach = 0;
};

template <typename Camera>
struct HeadViewResidual {
  HeadViewCommand command;
  std::vector<Eigen::Vector3d> points_in_target;
  std::vector<Eigen::Vector2d> pixels;
  double sigma_px = 1.0;
  double huber_k = 0.0;
  WarpSpan span;  // of the board's bow

  int NumResiduals() const { return 2 * static_cast<int>(pixels.size()); }

  // warp: the board's bow [2] (fitting/board_warp.h); a flat board is a warp held at zero.
  template <typename T>
  bool operator()(const T* pan,
                  const T* tilt,
                  const T* neck,
                  const T* mount,
                  const T* centres,
                  const T* base_from_target,
                  const T* camera,
                  const T* warp,
                  T* residual) const {
    const T pan_rad = models::ServoMap::JointAngle(pan, command.pan_direction, command.pan_us, command.pan_approach);
    const T tilt_rad =
        models::ServoMap::JointAngle(tilt, command.tilt_direction, command.tilt_us, command.tilt_approach);
    const T neck_rad =
        models::ServoMap::JointAngle(neck, command.neck_direction, command.neck_us, command.neck_approach);
    T centre[3];
    EyeCentreOfCentres(centres, command.eye, centre);
    // Same chain as models::PointInCam, composed once per view.
    const models::Rigid3<T> cam_from_target = CamFromEyeOfMount(mount) *
                                              models::HeadFromEye(centre, pan_rad, tilt_rad).Inverse() *
                                              models::HeadFromBase(neck_rad) * models::Rigid3<T>::Map(base_from_target);
    for (size_t i = 0; i < pixels.size(); ++i) {
      const Eigen::Matrix<T, 3, 1> p = cam_from_target * WarpedPoint(warp, points_in_target[i], span);
      T pixel[2];
      if (!Camera::Project(camera, p.data(), pixel)) return false;
      T ex = (pixel[0] - pixels[i].x()) / sigma_px;
      T ey = (pixel[1] - pixels[i].y()) / sigma_px;
      if (huber_k > 0) {
        const T s = ex * ex + ey * ey;
        if (s > T(huber_k * huber_k)) {
          // rho(s) = 2 k sqrt(s) - k^2; scale = sqrt(rho / s).
          const T root = ceres::sqrt(s);
          const T scale = ceres::sqrt((T(2 * huber_k) * root - T(huber_k * huber_k)) / s);
          ex = ex * scale;
          ey = ey * scale;
        }
      }
      residual[2 * i] = ex;
      residual[2 * i + 1] = ey;
    }
    return true;
  }
};

// Prior on a parameter block: residual = L^T (x - mean) with L L^T = information, i.e. the
// block is whitened by its prior covariance (intrinsics from a previous fit).
template <int kSize>
struct GaussianPriorResidual {
  Eigen::Matrix<double, kSize, 1> mean;
  Eigen::Matrix<double, kSize, kSize> sqrt_information;  // upper-triangular, rows = residuals

  template <typename T>
  bool operator()(const T* x, T* residual) const {
    for (int r = 0; r < kSize; ++r) {
      T sum(0);
      for (int c = 0; c < kSize; ++c) sum += sqrt_information(r, c) * (x[c] - mean(c));
      residual[r] = sum;
    }
    return true;
  }
};

}  // namespace owlcal::fitting
