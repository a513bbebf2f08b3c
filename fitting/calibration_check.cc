#include "fitting/calibration_check.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>

#include "fitting/format.h"
#include "models/units.h"

namespace owlcal::fitting {
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

struct Pair {
  int frame_index = 0;
  calib::View view[2];
};

// Which global parameters float, in the layout [left params, right params, rv (3), T (3)].
using FreeMask = std::vector<bool>;

// The rig's parameters in the check's blocks, and back.
struct Blocks {
  models::DistortionModel model[2];
  std::vector<double> camera[2];
  double right_from_left[6];
  std::vector<std::array<double, 6>> poses;  // left_from_target per pair
};

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

struct SolveOutcome {
  bool ok = false;
  double rms_px[2] = {0, 0}, rms_joint_px = 0;
  double sum_sq[2] = {0, 0};
  int n[2] = {0, 0};
  int num_free = 0;
  Eigen::MatrixXd cov;  // [left params, right params, rv, T] (unit corner noise), zero rows for fixed
  std::vector<std::array<double, 2>> view_rms;
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

// Rectified y_left - y_right of every corner seen in both views, per pair (mean) and all.
std::vector<double> EpipolarDy(const StereoRig& rig, const std::vector<Pair>& pairs, std::vector<double>* view_mean) {
  const Rectification rect = RectifyRig(rig);
  std::vector<double> dy;
  if (view_mean) view_mean->clear();
  for (const Pair& p : pairs) {
    std::map<int, cv::Point2d> right;
    for (size_t k = 0; k < p.view[1].pixels.size(); ++k)
      right[p.view[1].corner_ids[k]] = cv::Point2d(p.view[1].pixels[k].x(), p.view[1].pixels[k].y());
    std::vector<cv::Point2d> l, r;
    for (size_t k = 0; k < p.view[0].pixels.size(); ++k) {
      auto it = right.find(p.view[0].corner_ids[k]);
      if (it == right.end()) continue;
      l.emplace_back(p.view[0].pixels[k].x(), p.view[0].pixels[k].y());
      r.push_back(it->second);
    }
    double sum = 0;
    if (!l.empty()) {
      std::vector<cv::Point2d> lu, ru;
      cv::undistortPoints(
          l, lu, CameraMatrix(rig.cameras[0]), DistCoeffs(rig.cameras[0]), cv::Mat(rect.R1), cv::Mat(rect.P1));
      cv::undistortPoints(
          r, ru, CameraMatrix(rig.cameras[1]), DistCoeffs(rig.cameras[1]), cv::Mat(rect.R2), cv::Mat(rect.P2));
      for (size_t k = 0; k < lu.size(); ++k) dy.push_back(lu[k].y - ru[k].y), sum += lu[k].y - ru[k].y;
    }
    if (view_mean) view_mean->push_back(l.empty() ? 0.0 : sum / double(l.size()));
  }
  return dy;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / double(v.size()));
}

// Names and display scale of the covariance layout [left params, right params, rv, T].
struct Layout {
  std::vector<std::string> names, units;
  std::vector<double> scale;  // display value = scale * parameter
};
Layout MakeLayout(const StereoRig& rig) {
  Layout l;
  const char* base[4] = {"fx", "fy", "cx", "cy"};
  for (int e = 0; e < 2; ++e) {
    const std::string eye = e == 0 ? "left." : "right.";
    for (size_t k = 0; k < rig.cameras[e].params.size(); ++k) {
      l.names.push_back(eye + (k < 4 ? std::string(base[k]) : "d" + std::to_string(k - 4)));
      l.units.push_back(k < 4 ? "px" : "");
      l.scale.push_back(1);
    }
  }
  for (const char* n : {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"})
    l.names.push_back(n), l.units.push_back("deg"), l.scale.push_back(kRadToDeg);
  for (const char* n : {"stereo.tx_mm", "stereo.ty_mm", "stereo.tz_mm"})
    l.names.push_back(n), l.units.push_back("mm"), l.scale.push_back(1000);
  return l;
}

std::vector<CheckedParameter> Compare(const StereoRig& rig,
                                      const std::vector<double>& calibrated,
                                      const std::vector<double>& refit,
                                      const Eigen::MatrixXd& cov_refit,
                                      const std::vector<int>& indices,
                                      double moved_sigma) {
  const Layout l = MakeLayout(rig);
  const int n = rig.NumParams();
  const bool has_cov = rig.covariance.rows() == n && rig.covariance.cols() == n;
  std::vector<CheckedParameter> out;
  for (int i : indices) {
    CheckedParameter p;
    p.name = l.names[i];
    p.unit = l.units[i];
    p.calibrated = l.scale[i] * calibrated[i];
    p.refit = l.scale[i] * refit[i];
    p.sigma_calibration = has_cov ? l.scale[i] * std::sqrt(std::max(0.0, rig.covariance(i, i))) : 0.0;
    p.sigma_refit = l.scale[i] * std::sqrt(std::max(0.0, cov_refit(i, i)));
    const double s = std::hypot(p.sigma_calibration, p.sigma_refit);
    p.z = s > 0 ? (p.refit - p.calibrated) / s : 0.0;
    p.moved = std::abs(p.z) > moved_sigma;
    out.push_back(p);
  }
  return out;
}

}  // namespace

bool CalibrationCheckOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "CalibrationCheckOptions." + m;
    return false;
  };
  if (min_pairs < 2) return fail("min_pairs must be >= 2");
  if (!(moved_sigma > 0)) return fail("moved_sigma must be > 0");
  if (!(max_rms_ratio >= 1)) return fail("max_rms_ratio must be >= 1");
  if (!(min_rms_excess_px >= 0)) return fail("min_rms_excess_px must be >= 0");
  if (!(max_epipolar_rms_px > 0)) return fail("max_epipolar_rms_px must be > 0");
  if (!(max_range_error_pct > 0)) return fail("max_range_error_pct must be > 0");
  if (!(single_chi2 > 0)) return fail("single_chi2 must be > 0");
  if (!(min_explained > 0 && min_explained <= 1)) return fail("min_explained must be in (0, 1]");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  return true;
}

CalibrationCheck CheckCalibration(const StereoRig& rig,
                                  const std::vector<calib::CornerObservation>& observations,
                                  const CalibrationCheckOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  CalibrationCheck c;
  const int n = rig.NumParams();
  c.calibration_has_covariance = rig.covariance.rows() == n && rig.covariance.cols() == n;
  std::map<int, Pair> by_frame;
  for (const calib::View& v : calib::GroupIntoViews(observations)) {
    if (v.eye != 0 && v.eye != 1) continue;
    by_frame[v.frame_index].frame_index = v.frame_index;
    by_frame[v.frame_index].view[v.eye] = v;
  }
  std::vector<Pair> pairs;
  for (auto& [f, p] : by_frame) {
    if (p.view[0].pixels.size() >= 6 && p.view[1].pixels.size() >= 6)
      pairs.push_back(p);
    else
      c.unpaired_frames.push_back(f);
  }
  c.num_pairs = int(pairs.size());
  if (c.num_pairs < options.min_pairs) {
    c.message = "only " + std::to_string(c.num_pairs) + " image pair(s) with the board in both eyes (needs " +
                std::to_string(options.min_pairs) + ")";
    return c;
  }
  // Initial board poses from the left views; per-eye RMS with each eye's own pose.
  Blocks fixed = BlocksFromRig(rig);
  double mono_sq[2] = {0, 0};
  for (const Pair& p : pairs) {
    std::array<double, 6> pose[2];
    for (int e = 0; e < 2; ++e) {
      double rms = 0;
      if (!PoseOfView(rig.cameras[e], p.view[e], &pose[e], &rms)) {
        c.message =
            "frame " + std::to_string(p.frame_index) + ": no board pose for the " + (e ? "right" : "left") + " eye";
        return c;
      }
      mono_sq[e] += rms * rms * double(p.view[e].pixels.size());
      c.num_corners[e] += int(p.view[e].pixels.size());
    }
    fixed.poses.push_back(pose[0]);
  }
  for (int e = 0; e < 2; ++e) c.mono_rms_px[e] = std::sqrt(mono_sq[e] / c.num_corners[e]);

  // Free masks over [left params, right params, rv, T].
  const int n0 = int(rig.cameras[0].params.size()), n1 = int(rig.cameras[1].params.size());
  std::vector<int> ext_idx, all_idx;
  for (int i = 0; i < 6; ++i) ext_idx.push_back(n0 + n1 + i);
  for (int k = 0; k < 4; ++k) all_idx.push_back(k);
  for (int k = 0; k < 4; ++k) all_idx.push_back(n0 + k);
  all_idx.insert(all_idx.end(), ext_idx.begin(), ext_idx.end());
  auto mask = [&](const std::vector<int>& idx) {
    FreeMask m(n, false);
    for (int i : idx) m[i] = true;
    return m;
  };

  // Calibration held fixed.
  const SolveOutcome f = Solve(pairs, mask({}), false, options.max_iterations, &fixed);
  if (!f.ok) {
    c.message = "the board-pose fit with the calibration fixed failed";
    return c;
  }
  for (int e = 0; e < 2; ++e) {
    c.rms_px[e] = f.rms_px[e];
    c.sigma_rms_px[e] = f.rms_px[e] / std::sqrt(2.0 * 2 * f.n[e]);  // 2 n residual components
  }
  c.rms_joint_px = f.rms_joint_px;
  c.sigma_rms_joint_px = f.rms_joint_px / std::sqrt(2.0 * 2 * (f.n[0] + f.n[1]));
  std::vector<double> view_dy;
  const std::vector<double> dy = EpipolarDy(rig, pairs, &view_dy);
  c.epipolar_num_corners = int(dy.size());
  double sum = 0;
  for (double v : dy) sum += v, c.epipolar_max_dy_px = std::max(c.epipolar_max_dy_px, std::abs(v));
  c.epipolar_mean_dy_px = dy.empty() ? 0 : sum / double(dy.size());
  c.epipolar_rms_dy_px = Rms(dy);
  double var = 0;
  for (double v : dy) var += (v - c.epipolar_mean_dy_px) * (v - c.epipolar_mean_dy_px);
  c.sigma_epipolar_mean_dy_px = dy.size() > 1 ? std::sqrt(var / double(dy.size() - 1) / double(dy.size())) : 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    CheckedView v;
    v.frame_index = pairs[i].frame_index;
    for (int e = 0; e < 2; ++e) v.num_corners[e] = int(pairs[i].view[e].pixels.size()), v.rms_px[e] = f.view_rms[i][e];
    v.mean_dy_px = view_dy[i];
    c.views.push_back(v);
  }

  // Refit A (extrinsics) and B (fx fy cx cy + extrinsics), from the fixed solution's poses.
  Blocks a = fixed, b = fixed;
  const SolveOutcome ra = Solve(pairs, mask(ext_idx), true, options.max_iterations, &a);
  const SolveOutcome rb = Solve(pairs, mask(all_idx), true, options.max_iterations, &b);
  if (!ra.ok || !rb.ok) {
    c.message = "a refit on the new images failed";
    return c;
  }
  c.refit_extrinsics_rms_px = ra.rms_joint_px;
  c.refit_all_rms_px = rb.rms_joint_px;
  const int num_res = 2 * (rb.n[0] + rb.n[1]);
  c.corner_sigma_px = std::sqrt((rb.sum_sq[0] + rb.sum_sq[1]) / std::max(1, num_res - rb.num_free));
  const double var_c = c.corner_sigma_px * c.corner_sigma_px;
  const StereoRig rig_b = RigFromBlocks(rig, b);
  c.refit_all_epipolar_rms_dy_px = Rms(EpipolarDy(rig_b, pairs, nullptr));
  auto flat = [](const Blocks& x) {
    std::vector<double> v = x.camera[0];
    v.insert(v.end(), x.camera[1].begin(), x.camera[1].end());
    v.insert(v.end(), x.right_from_left, x.right_from_left + 6);
    return v;
  };
  const std::vector<double> p_cal = flat(fixed), p_a = flat(a), p_b = flat(b);
  c.extrinsics = Compare(rig, p_cal, p_a, ra.cov * var_c, ext_idx, options.moved_sigma);
  c.all = Compare(rig, p_cal, p_b, rb.cov * var_c, all_idx, options.moved_sigma);

  // What moved: each parameter freed alone; the share of the excess cost (fixed - refit B) it
  // removes, and its chi-square (cost drop / corner sigma^2, 1 dof).
  const double cost_fixed = 0.5 * (f.sum_sq[0] + f.sum_sq[1]), cost_b = 0.5 * (rb.sum_sq[0] + rb.sum_sq[1]);
  const double excess = std::max(1e-12, cost_fixed - cost_b);
  const Layout layout = MakeLayout(rig);
  for (int i : all_idx) {
    Blocks one = fixed;
    const SolveOutcome r1 = Solve(pairs, mask({i}), false, options.max_iterations, &one);
    if (!r1.ok) continue;
    ParameterDiagnosis d;
    d.name = layout.names[i];
    d.unit = layout.units[i];
    d.change = layout.scale[i] * (flat(one)[i] - p_cal[i]);
    const double drop = cost_fixed - 0.5 * (r1.sum_sq[0] + r1.sum_sq[1]);
    d.explained = std::clamp(drop / excess, 0.0, 1.0);
    d.chi2 = 2 * drop / var_c;
    d.significant = d.chi2 > options.single_chi2;
    c.single.push_back(d);
  }
  std::sort(c.single.begin(), c.single.end(), [](auto& x, auto& y) { return x.explained > y.explained; });
  for (const auto& d : c.single)
    if (d.significant && d.explained >= options.min_explained)
      c.moved.push_back(d.name + " " + (d.change >= 0 ? "+" : "") + FixedOrDash(d.change, 3) + " " + d.unit +
                        " alone explains " + FixedOrDash(100 * d.explained, 0) + " % of the disagreement (chi2 " +
                        FixedOrDash(d.chi2, 0) + ")");

  // Ranging: a point refit B puts on the left axis at 1 m, triangulated by the calibration;
  // its sigma from refit B's covariance (central differences over the free parameters).
  auto range_of = [&](const std::vector<double>& p) {
    Blocks x = fixed;
    x.camera[0].assign(p.begin(), p.begin() + n0);
    x.camera[1].assign(p.begin() + n0, p.begin() + n0 + n1);
    std::copy(p.begin() + n0 + n1, p.end(), x.right_from_left);
    const StereoRig r = RigFromBlocks(rig, x);
    const Eigen::Vector3d x_left(0, 0, 1.0), x_right = r.right_from_left * x_left;
    Eigen::Vector2d pl, pr;
    if (!r.cameras[0].Project(x_left.data(), pl.data()) || !r.cameras[1].Project(x_right.data(), pr.data()))
      return std::numeric_limits<double>::quiet_NaN();
    const auto z = TriangulateDepth(rig, RigParameters(rig), pl, pr, Eigen::Vector3d::UnitZ());
    return z ? *z : std::numeric_limits<double>::quiet_NaN();
  };
  c.range_at_1m_m = range_of(p_b);
  {
    const Eigen::MatrixXd cov_b = rb.cov * var_c;
    Eigen::VectorXd J = Eigen::VectorXd::Zero(n);
    for (int i : all_idx) {
      const double h = 1e-3 * std::max(1e-9, std::sqrt(std::max(0.0, cov_b(i, i))));
      std::vector<double> pp = p_b, pm = p_b;
      pp[i] += h;
      pm[i] -= h;
      J[i] = (range_of(pp) - range_of(pm)) / (2 * h);
    }
    c.sigma_range_at_1m_m = std::sqrt(std::max(0.0, J.dot(cov_b * J)));
  }

  // Verdict.
  const double rms_limit = options.max_rms_ratio * c.refit_all_rms_px + options.min_rms_excess_px;
  if (c.rms_joint_px > rms_limit)
    c.reasons.push_back("reprojection RMS with the calibration fixed " + FixedOrDash(c.rms_joint_px, 3) + " px > " +
                        FixedOrDash(rms_limit, 3) + " px (" + FixedOrDash(options.max_rms_ratio, 2) +
                        " x the refit's " + FixedOrDash(c.refit_all_rms_px, 3) + " + " +
                        FixedOrDash(options.min_rms_excess_px, 2) + ")");
  const double epi_limit = std::max(options.max_epipolar_rms_px, 2 * c.refit_all_epipolar_rms_dy_px);
  if (c.epipolar_rms_dy_px > epi_limit)
    c.reasons.push_back("rectified epipolar RMS " + FixedOrDash(c.epipolar_rms_dy_px, 3) + " px > " +
                        FixedOrDash(epi_limit, 3) + " px (mean dy " + FixedOrDash(c.epipolar_mean_dy_px, 3) + " +- " +
                        FixedOrDash(c.sigma_epipolar_mean_dy_px, 3) + " px)");
  // Ranging: beyond the limit AND beyond 3 sigma of what the new images can tell.
  const double range_pct = 100 * (c.range_at_1m_m - 1.0), sigma_pct = 100 * c.sigma_range_at_1m_m;
  if (!std::isfinite(range_pct) ||
      (std::abs(range_pct) > options.max_range_error_pct && std::abs(range_pct) > 3 * sigma_pct))
    c.reasons.push_back("ranging: a point at 1 m by the new images is ranged at " + FixedOrDash(c.range_at_1m_m, 4) +
                        " m by the calibration (" + FixedOrDash(range_pct, 2) + " % +- " + FixedOrDash(sigma_pct, 2) +
                        " %, limit " + FixedOrDash(options.max_range_error_pct, 1) + " % and 3 sigma)");
  c.verdict = c.reasons.empty() ? "still valid" : "recalibrate";
  c.ok = true;
  return c;
}

}  // namespace owlcal::fitting
