#include "fitting/calibration_check_problem.h"

#include <cmath>
#include <memory>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>

namespace owlcal::fitting::internal::check {
namespace {

// Corner of the left view: cam = left_from_target (angle-axis, t) * point.
template <typename Camera>
struct LeftCorner {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point;
  template <typename T>
  bool operator()(const T* camera, const T* pose, T* r) const {
    T p[3], q[3] = {T(point.x()), T(point.y()), T(point.z())}, px[2];
    ceres::AngleAxisRotatePoint(pose, q, p);
    for (int i = 0; i < 3; ++i) p[i] += pose[3 + i];
    if (!Camera::Project(camera, p, px)) return false;
    r[0] = px[0] - T(pixel.x());
    r[1] = px[1] - T(pixel.y());
    return true;
  }
};

// Corner of the right view: cam = right_from_left * left_from_target * point (both angle-axis, t).
template <typename Camera>
struct RightCorner {
  Eigen::Vector2d pixel;
  Eigen::Vector3d point;
  template <typename T>
  bool operator()(const T* camera, const T* right_from_left, const T* pose, T* r) const {
    T p[3], l[3], q[3] = {T(point.x()), T(point.y()), T(point.z())}, px[2];
    ceres::AngleAxisRotatePoint(pose, q, l);
    for (int i = 0; i < 3; ++i) l[i] += pose[3 + i];
    ceres::AngleAxisRotatePoint(right_from_left, l, p);
    for (int i = 0; i < 3; ++i) p[i] += right_from_left[3 + i];
    if (!Camera::Project(camera, p, px)) return false;
    r[0] = px[0] - T(pixel.x());
    r[1] = px[1] - T(pixel.y());
    return true;
  }
};

ceres::CostFunction* Cost(const models::CameraIntrinsics& cam,
                          bool right,
                          const Eigen::Vector2d& px,
                          const Eigen::Vector3d& pt) {
  if (cam.model == models::DistortionModel::kOpenCv5) {
    if (right)
      return new ceres::AutoDiffCostFunction<RightCorner<models::Camera5>, 2, models::Camera5::kNumParams, 6, 6>(
          new RightCorner<models::Camera5>{px, pt});
    return new ceres::AutoDiffCostFunction<LeftCorner<models::Camera5>, 2, models::Camera5::kNumParams, 6>(
        new LeftCorner<models::Camera5>{px, pt});
  }
  if (right)
    return new ceres::AutoDiffCostFunction<RightCorner<models::Camera8>, 2, models::Camera8::kNumParams, 6, 6>(
        new RightCorner<models::Camera8>{px, pt});
  return new ceres::AutoDiffCostFunction<LeftCorner<models::Camera8>, 2, models::Camera8::kNumParams, 6>(
      new LeftCorner<models::Camera8>{px, pt});
}

}  // namespace

Blocks BlocksFromRig(const StereoRig& rig) {
  Blocks b;
  b.model[0] = rig.cameras[0].model;
  b.model[1] = rig.cameras[1].model;
  b.camera[0] = rig.cameras[0].params;
  b.camera[1] = rig.cameras[1].params;
  const Eigen::AngleAxisd aa(rig.right_from_left.rotation);
  const Eigen::Vector3d rv = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) {
    b.right_from_left[i] = rv[i];
    b.right_from_left[3 + i] = rig.right_from_left.translation[i];
  }
  return b;
}

StereoRig RigFromBlocks(const StereoRig& like, const Blocks& b) {
  StereoRig r = like;
  r.cameras[0].params = b.camera[0];
  r.cameras[1].params = b.camera[1];
  const Eigen::Vector3d rv(b.right_from_left[0], b.right_from_left[1], b.right_from_left[2]);
  const double angle = rv.norm();
  r.right_from_left.rotation =
      angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, rv / angle)) : Eigen::Quaterniond::Identity();
  r.right_from_left.translation = Eigen::Vector3d(b.right_from_left[3], b.right_from_left[4], b.right_from_left[5]);
  r.covariance.resize(0, 0);
  return r;
}

cv::Mat CameraMatrix(const models::CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.params[0], 0, c.params[2], 0, c.params[1], c.params[3], 0, 0, 1);
}
cv::Mat DistCoeffs(const models::CameraIntrinsics& c) { return cv::Mat(c.Distortion(), true).reshape(1, 1); }

// Board pose and RMS of one view with the camera fixed (cv::solvePnP, iterative LM).
bool PoseOfView(const models::CameraIntrinsics& cam, const calib::View& v, std::array<double, 6>* pose, double* rms) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (size_t i = 0; i < v.pixels.size(); ++i) {
    obj.emplace_back(v.points_in_target[i].x(), v.points_in_target[i].y(), v.points_in_target[i].z());
    img.emplace_back(v.pixels[i].x(), v.pixels[i].y());
  }
  cv::Mat rvec, tvec;
  if (!cv::solvePnP(obj, img, CameraMatrix(cam), DistCoeffs(cam), rvec, tvec)) return false;
  std::vector<cv::Point2d> proj;
  cv::projectPoints(obj, rvec, tvec, CameraMatrix(cam), DistCoeffs(cam), proj);
  double s = 0;
  for (size_t i = 0; i < img.size(); ++i) s += std::pow(cv::norm(proj[i] - img[i]), 2);
  *rms = std::sqrt(s / double(img.size()));
  for (int i = 0; i < 3; ++i) (*pose)[i] = rvec.at<double>(i), (*pose)[3 + i] = tvec.at<double>(i);
  return true;
}

SolveOutcome Solve(
    const std::vector<Pair>& pairs, const FreeMask& free, bool want_covariance, int max_iterations, Blocks* b) {
  SolveOutcome out;
  ceres::Problem problem;
  std::vector<std::pair<ceres::ResidualBlockId, int>> ids;  // residual, eye
  std::vector<int> id_pair;
  models::CameraIntrinsics cams[2];
  for (int e = 0; e < 2; ++e) cams[e].model = b->model[e];
  for (size_t i = 0; i < pairs.size(); ++i)
    for (int e = 0; e < 2; ++e) {
      const calib::View& v = pairs[i].view[e];
      for (size_t k = 0; k < v.pixels.size(); ++k) {
        ceres::ResidualBlockId id =
            e == 0 ? problem.AddResidualBlock(Cost(cams[0], false, v.pixels[k], v.points_in_target[k]),
                                              nullptr,
                                              b->camera[0].data(),
                                              b->poses[i].data())
                   : problem.AddResidualBlock(Cost(cams[1], true, v.pixels[k], v.points_in_target[k]),
                                              nullptr,
                                              b->camera[1].data(),
                                              b->right_from_left,
                                              b->poses[i].data());
        ids.emplace_back(id, e);
        id_pair.push_back(int(i));
      }
    }
  // Each global block: constant, partly free (SubsetManifold over the fixed entries) or free.
  const int n0 = int(b->camera[0].size()), n1 = int(b->camera[1].size());
  double* blocks[3] = {b->camera[0].data(), b->camera[1].data(), b->right_from_left};
  const int offset[3] = {0, n0, n0 + n1}, size[3] = {n0, n1, 6};
  out.num_free = 6 * int(pairs.size());
  for (int k = 0; k < 3; ++k) {
    std::vector<int> fixed;
    for (int j = 0; j < size[k]; ++j)
      if (!free[offset[k] + j]) fixed.push_back(j);
    out.num_free += size[k] - int(fixed.size());
    if (int(fixed.size()) == size[k])
      problem.SetParameterBlockConstant(blocks[k]);
    else if (!fixed.empty())
      problem.SetManifold(blocks[k], new ceres::SubsetManifold(size[k], fixed));
  }
  ceres::Solver::Options so;
  so.max_num_iterations = max_iterations;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) return out;
  out.view_rms.assign(pairs.size(), {0, 0});
  std::vector<std::array<int, 2>> view_n(pairs.size(), {0, 0});
  for (size_t j = 0; j < ids.size(); ++j) {
    double r[2];
    problem.EvaluateResidualBlock(ids[j].first, false, nullptr, r, nullptr);
    const double s = r[0] * r[0] + r[1] * r[1];
    out.sum_sq[ids[j].second] += s;
    out.n[ids[j].second] += 1;
    out.view_rms[id_pair[j]][ids[j].second] += s;
    view_n[id_pair[j]][ids[j].second] += 1;
  }
  for (size_t i = 0; i < pairs.size(); ++i)
    for (int e = 0; e < 2; ++e) out.view_rms[i][e] = std::sqrt(out.view_rms[i][e] / std::max(1, view_n[i][e]));
  for (int e = 0; e < 2; ++e) out.rms_px[e] = std::sqrt(out.sum_sq[e] / std::max(1, out.n[e]));
  out.rms_joint_px = std::sqrt((out.sum_sq[0] + out.sum_sq[1]) / std::max(1, out.n[0] + out.n[1]));
  out.ok = true;
  if (!want_covariance) return out;
  // Covariance of the free global blocks (board poses marginalised), for unit corner noise.
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  co.min_reciprocal_condition_number = 1e-14;
  ceres::Covariance covariance(co);
  std::vector<const double*> cov_blocks;
  for (int k = 0; k < 3; ++k)
    if (!problem.IsParameterBlockConstant(blocks[k])) cov_blocks.push_back(blocks[k]);
  std::vector<std::pair<const double*, const double*>> req;
  for (const double* x : cov_blocks)
    for (const double* y : cov_blocks) req.emplace_back(x, y);
  const int n = n0 + n1 + 6;
  out.cov = Eigen::MatrixXd::Zero(n, n);
  if (!covariance.Compute(req, &problem)) return out;
  auto index = [&](const double* x) { return x == blocks[0] ? 0 : x == blocks[1] ? 1 : 2; };
  for (const double* x : cov_blocks)
    for (const double* y : cov_blocks) {
      const int i = index(x), j = index(y);
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> m(size[i], size[j]);
      covariance.GetCovarianceBlock(x, y, m.data());
      out.cov.block(offset[i], offset[j], size[i], size[j]) = m;
    }
  return out;
}

}  // namespace owlcal::fitting::internal::check
