#pragma once
// Reprojection residuals shared by the intrinsics and stereo problems (fitting/ internal).
// Parameter blocks: camera [fx fy cx cy dist...] (models::OpenCvCamera<N> order), poses as
// 7-blocks [qx qy qz qw tx ty tz] (models::Rigid3). Residual = (projection - measured) /
// sigma_px, so the problem is whitened (docs/conventions.md).
#include <ceres/autodiff_cost_function.h>
#include <Eigen/Core>

#include "fitting/board_warp.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting::internal {

// The whitened reprojection residual of a point p in the camera's frame: (projection - pixel) *
// inv_sigma. tie_fy_to_fx: fixed aspect ratio, fy := fx.
template <typename Camera, typename T>
bool WhitenedReprojection(const T* camera,
                          bool tie_fy_to_fx,
                          const Eigen::Matrix<T, 3, 1>& p,
                          const Eigen::Vector2d& pixel,
                          double inv_sigma,
                          T* residual) {
  T params[Camera::kNumParams];
  for (int i = 0; i < Camera::kNumParams; ++i) params[i] = camera[i];
  if (tie_fy_to_fx) params[1] = params[0];
  T px[2];
  if (!Camera::Project(params, p.data(), px)) return false;
  residual[0] = (px[0] - T(pixel.x())) * T(inv_sigma);
  residual[1] = (px[1] - T(pixel.y())) * T(inv_sigma);
  return true;
}

// Corner seen by a camera whose pose cam_from_target is one block; on a bowed board
// (fitting/board_warp.h) the warp [2] is one more block (WarpedCornerResidual).
template <typename Camera>
struct CornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;  // fixed aspect ratio: fy := fx
  WarpSpan span;

  template <typename T>
  bool Evaluate(const T* camera, const T* cam_from_target, const T* warp, T* residual) const {
    const Eigen::Matrix<T, 3, 1> p = models::Rigid3<T>::Map(cam_from_target) * WarpedPoint(warp, point_in_target, span);
    return WhitenedReprojection<Camera>(camera, tie_fy_to_fx, p, pixel, inv_sigma, residual);
  }
  template <typename T>
  bool operator()(const T* camera, const T* cam_from_target, T* residual) const {
    return Evaluate(camera, cam_from_target, static_cast<const T*>(nullptr), residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& pixel,
                                     const Eigen::Vector3d& point,
                                     double inv_sigma,
                                     bool tie) {
    return new ceres::AutoDiffCostFunction<CornerResidual, 2, Camera::kNumParams, 7>(
        new CornerResidual{pixel, point, inv_sigma, tie, {}});
  }
};

template <typename Camera>
struct WarpedCornerResidual : CornerResidual<Camera> {
  template <typename T>
  bool operator()(const T* camera, const T* cam_from_target, const T* warp, T* residual) const {
    return this->Evaluate(camera, cam_from_target, warp, residual);
  }

  static ceres::CostFunction* Create(
      const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, const WarpSpan& span, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<WarpedCornerResidual, 2, Camera::kNumParams, 7, 2>(
        new WarpedCornerResidual{{pixel, point, inv_sigma, tie, span}});
  }
};

// Corner seen by the right camera of a stereo pair: cam_from_target = right_from_left *
// left_from_target; on a bowed board the warp [2] is one more block (WarpedStereoCornerResidual).
template <typename Camera>
struct StereoCornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;
  WarpSpan span;

  template <typename T>
  bool Evaluate(
      const T* camera, const T* right_from_left, const T* left_from_target, const T* warp, T* residual) const {
    const Eigen::Matrix<T, 3, 1> p =
        models::Rigid3<T>::Map(right_from_left) *
        (models::Rigid3<T>::Map(left_from_target) * WarpedPoint(warp, point_in_target, span));
    return WhitenedReprojection<Camera>(camera, tie_fy_to_fx, p, pixel, inv_sigma, residual);
  }
  template <typename T>
  bool operator()(const T* camera, const T* right_from_left, const T* left_from_target, T* residual) const {
    return Evaluate(camera, right_from_left, left_from_target, static_cast<const T*>(nullptr), residual);
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& pixel,
                                     const Eigen::Vector3d& point,
                                     double inv_sigma,
                                     bool tie) {
    return new ceres::AutoDiffCostFunction<StereoCornerResidual, 2, Camera::kNumParams, 7, 7>(
        new StereoCornerResidual{pixel, point, inv_sigma, tie, {}});
  }
};

template <typename Camera>
struct WarpedStereoCornerResidual : StereoCornerResidual<Camera> {
  template <typename T>
  bool operator()(
      const T* camera, const T* right_from_left, const T* left_from_target, const T* warp, T* residual) const {
    return this->Evaluate(camera, right_from_left, left_from_target, warp, residual);
  }

  static ceres::CostFunction* Create(
      const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, const WarpSpan& span, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<WarpedStereoCornerResidual, 2, Camera::kNumParams, 7, 7, 2>(
        new WarpedStereoCornerResidual{{pixel, point, inv_sigma, tie, span}});
  }
};

}  // namespace owlcal::fitting::internal
