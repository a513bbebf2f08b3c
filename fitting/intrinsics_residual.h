#pragma once
// Reprojection residuals shared by the intrinsics and stereo problems (fitting/ internal).
// Parameter blocks: camera [fx fy cx cy dist...] (models::OpenCvCamera<N> order), poses as
// 7-blocks [qx qy qz qw tx ty tz] (models::Rigid3). Residual = (projection - measured) /
// sigma_px, so the problem is whitened (docs/conventions.md).
#include <Eigen/Core>
#include <ceres/autodiff_cost_function.h>

#include "fitting/board_warp.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting::internal {

// Corner seen by a camera whose pose cam_from_target is one block.
template <typename Camera>
struct CornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;  // fixed aspect ratio: fy := fx

  template <typename T>
  bool operator()(const T* camera, const T* cam_from_target, T* residual) const {
    T params[Camera::kNumParams];
    for (int i = 0; i < Camera::kNumParams; ++i) params[i] = camera[i];
    if (tie_fy_to_fx) params[1] = params[0];
    const Eigen::Matrix<T, 3, 1> p = models::Rigid3<T>::Map(cam_from_target) * point_in_target.cast<T>();
    T px[2];
    if (!Camera::Project(params, p.data(), px)) return false;
    residual[0] = (px[0] - T(pixel.x())) * T(inv_sigma);
    residual[1] = (px[1] - T(pixel.y())) * T(inv_sigma);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<CornerResidual, 2, Camera::kNumParams, 7>(
        new CornerResidual{pixel, point, inv_sigma, tie});
  }
};

// Corner seen by the right camera of a stereo pair: cam_from_target = right_from_left * left_from_target.
template <typename Camera>
struct StereoCornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;

  template <typename T>
  bool operator()(const T* camera, const T* right_from_left, const T* left_from_target, T* residual) const {
    T params[Camera::kNumParams];
    for (int i = 0; i < Camera::kNumParams; ++i) params[i] = camera[i];
    if (tie_fy_to_fx) params[1] = params[0];
    const Eigen::Matrix<T, 3, 1> p = models::Rigid3<T>::Map(right_from_left) *
                                     (models::Rigid3<T>::Map(left_from_target) * point_in_target.cast<T>());
    T px[2];
    if (!Camera::Project(params, p.data(), px)) return false;
    residual[0] = (px[0] - T(pixel.x())) * T(inv_sigma);
    residual[1] = (px[1] - T(pixel.y())) * T(inv_sigma);
    return true;
  }

  static ceres::CostFunction* Create(const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<StereoCornerResidual, 2, Camera::kNumParams, 7, 7>(
        new StereoCornerResidual{pixel, point, inv_sigma, tie});
  }
};

// CornerResidual on a bowed board (fitting/board_warp.h): one more block, the warp [2].
template <typename Camera>
struct WarpedCornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  WarpSpan span;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;

  template <typename T>
  bool operator()(const T* camera, const T* cam_from_target, const T* warp, T* residual) const {
    T params[Camera::kNumParams];
    for (int i = 0; i < Camera::kNumParams; ++i) params[i] = camera[i];
    if (tie_fy_to_fx) params[1] = params[0];
    const Eigen::Matrix<T, 3, 1> p = models::Rigid3<T>::Map(cam_from_target) * WarpedPoint(warp, point_in_target, span);
    T px[2];
    if (!Camera::Project(params, p.data(), px)) return false;
    residual[0] = (px[0] - T(pixel.x())) * T(inv_sigma);
    residual[1] = (px[1] - T(pixel.y())) * T(inv_sigma);
    return true;
  }

  static ceres::CostFunction* Create(
      const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, const WarpSpan& span, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<WarpedCornerResidual, 2, Camera::kNumParams, 7, 2>(
        new WarpedCornerResidual{pixel, point, span, inv_sigma, tie});
  }
};

// StereoCornerResidual on a bowed board: one more block, the warp [2].
template <typename Camera>
struct WarpedStereoCornerResidual {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point_in_target;
  WarpSpan span;
  double inv_sigma = 1.0;
  bool tie_fy_to_fx = false;

  template <typename T>
  bool operator()(
      const T* camera, const T* right_from_left, const T* left_from_target, const T* warp, T* residual) const {
    T params[Camera::kNumParams];
    for (int i = 0; i < Camera::kNumParams; ++i) params[i] = camera[i];
    if (tie_fy_to_fx) params[1] = params[0];
    const Eigen::Matrix<T, 3, 1> p =
        models::Rigid3<T>::Map(right_from_left) *
        (models::Rigid3<T>::Map(left_from_target) * WarpedPoint(warp, point_in_target, span));
    T px[2];
    if (!Camera::Project(params, p.data(), px)) return false;
    residual[0] = (px[0] - T(pixel.x())) * T(inv_sigma);
    residual[1] = (px[1] - T(pixel.y())) * T(inv_sigma);
    return true;
  }

  static ceres::CostFunction* Create(
      const Eigen::Vector2d& pixel, const Eigen::Vector3d& point, const WarpSpan& span, double inv_sigma, bool tie) {
    return new ceres::AutoDiffCostFunction<WarpedStereoCornerResidual, 2, Camera::kNumParams, 7, 7, 2>(
        new WarpedStereoCornerResidual{pixel, point, span, inv_sigma, tie});
  }
};

}  // namespace owlcal::fitting::internal
