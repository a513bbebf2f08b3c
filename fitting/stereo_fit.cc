#include "fitting/stereo_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "fitting/board_warp.h"
#include "fitting/intrinsics_residual.h"
#include "fitting/observability.h"
#include "io/number_text.h"
#include "models/units.h"

namespace owlcal::fitting {
namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
constexpr const char* kStereoEye[2] = {"left", "right"};

std::string StereoFmt(double v, int prec = 4) { return io::SignificantText(v, prec); }

Eigen::Vector3d RotVec(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd aa(q.normalized());
  return aa.angle() * aa.axis();
}

cv::Mat StereoCameraMatrix(const models::CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.params[0], 0, c.params[2], 0, c.params[1], c.params[3], 0, 0, 1);
}
cv::Mat StereoDistCoeffs(const models::CameraIntrinsics& c) {
  const std::vector<double> d = c.Distortion();
  return cv::Mat(d, true).reshape(1, 1);
}

}  // namespace

bool StereoFitOptions::Check(std::string* why) const {
  if (!intrinsics.Check(why)) return false;
  auto fail = [&](const std::string& m) {
    if (why) *why = "StereoFitOptions." + m;
    return false;
  };
  if (width <= 0 || height <= 0)
    return fail("width/height must be > 0, got " + std::to_string(width) + "x" + std::to_string(height));
  if (length_unit.empty()) return fail("length_unit must not be empty");
  if (rectify_alpha != -1 && (rectify_alpha < 0 || rectify_alpha > 1))
    return fail("rectify_alpha must be -1 or 0..1, got " + StereoFmt(rectify_alpha));
  if (max_iterations < 1) return fail("max_iterations must be >= 1, got " + std::to_string(max_iterations));
  return true;
}

namespace {

// One corner observation of the joint problem.
struct StereoObs {
  int eye, frame, corner;
  Eigen::Vector2d pixel;
  Eigen::Vector3d point;
};

// The joint problem's data: parameter blocks and observations.
struct StereoProblemData {
  int np = 0;  // params per camera
  std::vector<double> cam[2];
  std::array<double, 7> ext;  // right_from_left
  // Board poses: one per left-eye frame (left cam_from_target), one per right-only frame.
  std::vector<std::array<double, 7>> poses;
  std::map<int, int> pose_of_left_frame, pose_of_right_only_frame;
  std::vector<StereoObs> obs;  // minus each eye's rejected outliers
  double sigma_used[2] = {1, 1};
  std::array<double, 2> warp = {0, 0};  // board bow (options.fit_board_warp)
  WarpSpan span;
};

// Initial right_from_left: sign-aligned quaternion mean and median translation over pairs.
models::Rigid3d InitialRightFromLeft(const StereoFit& fit,
                                     const std::map<int, int>& left_of_frame,
                                     const std::map<int, int>& right_of_frame) {
  Eigen::Vector4d qsum = Eigen::Vector4d::Zero();
  std::vector<double> tx, ty, tz;
  Eigen::Quaterniond qref = Eigen::Quaterniond::Identity();
  for (size_t k = 0; k < fit.paired_frames.size(); ++k) {
    const int f = fit.paired_frames[k];
    const models::Rigid3d rl = fit.per_eye[1].cam_from_target[right_of_frame.at(f)] *
                               fit.per_eye[0].cam_from_target[left_of_frame.at(f)].Inverse();
    Eigen::Vector4d q = rl.rotation.coeffs();
    if (k == 0) qref = rl.rotation;
    if (q.dot(qref.coeffs()) < 0) q = -q;
    qsum += q;
    tx.push_back(rl.translation.x());
    ty.push_back(rl.translation.y());
    tz.push_back(rl.translation.z());
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  Eigen::Quaterniond q0(qsum(3), qsum(0), qsum(1), qsum(2));
  q0.normalize();
  return models::Rigid3d(q0, Eigen::Vector3d(median(tx), median(ty), median(tz)));
}

// Blocks from the per-eye fits, observations, and one pooled corner sigma for both eyes, so the
// joint solve minimises the plain sum of squared pixel errors (stereoCalibrate's objective).
StereoProblemData BuildStereoData(const std::vector<calib::View>* views[2],
                                  const models::Rigid3d& right_from_left,
                                  const std::map<int, int>& left_of_frame,
                                  const StereoFitOptions& options,
                                  StereoFit* fit) {
  StereoProblemData d;
  d.np = 4 + fit->per_eye[0].camera.NumDistortion();
  std::vector<calib::View> all = *views[0];
  all.insert(all.end(), views[1]->begin(), views[1]->end());
  d.span = WarpSpanOfViews(all);
  for (int e = 0; e < 2; ++e) d.cam[e] = fit->per_eye[e].camera.params;
  right_from_left.ToArray(d.ext.data());
  const std::vector<int>& fl = fit->per_eye[0].frame_indices;
  const std::vector<int>& fr = fit->per_eye[1].frame_indices;
  for (size_t i = 0; i < fl.size(); ++i) {
    std::array<double, 7> a;
    fit->per_eye[0].cam_from_target[i].ToArray(a.data());
    d.pose_of_left_frame[fl[i]] = int(d.poses.size());
    d.poses.push_back(a);
  }
  for (size_t i = 0; i < fr.size(); ++i) {
    if (left_of_frame.count(fr[i])) continue;
    std::array<double, 7> a;
    fit->per_eye[1].cam_from_target[i].ToArray(a.data());
    d.pose_of_right_only_frame[fr[i]] = int(d.poses.size());
    d.poses.push_back(a);
  }
  for (const auto& [f, i] : d.pose_of_left_frame) fit->frame_indices.push_back(f);
  for (const auto& [f, i] : d.pose_of_right_only_frame) fit->frame_indices.push_back(f);
  int ne[2] = {0, 0};
  for (int e = 0; e < 2; ++e) {
    std::set<std::pair<int, int>> rejected;
    for (const auto& r : fit->per_eye[e].rejected) {
      rejected.insert({r.frame_index, r.corner_id});
      fit->rejected.push_back(r);
    }
    const std::set<int> used_frames(fit->per_eye[e].frame_indices.begin(), fit->per_eye[e].frame_indices.end());
    for (const calib::View& v : *views[e]) {
      if (!used_frames.count(v.frame_index)) continue;
      for (size_t i = 0; i < v.pixels.size(); ++i) {
        if (rejected.count({v.frame_index, v.corner_ids[i]})) continue;
        d.obs.push_back({e, v.frame_index, v.corner_ids[i], v.pixels[i], v.points_in_target[i]});
        ++ne[e];
      }
    }
  }
  // Re-estimated from the joint residuals when corner_sigma_px is 0 (see FitStereo).
  const double s0 = fit->per_eye[0].corner_sigma_px, s1 = fit->per_eye[1].corner_sigma_px;
  const double pooled = std::sqrt((s0 * s0 * ne[0] + s1 * s1 * ne[1]) / std::max(1, ne[0] + ne[1]));
  for (int e = 0; e < 2; ++e)
    d.sigma_used[e] = options.intrinsics.corner_sigma_px > 0 ? options.intrinsics.corner_sigma_px
                                                             : std::max(1e-4, std::isfinite(pooled) ? pooled : 1.0);
  return d;
}

// Tangent names of the joint problem's globals: free intrinsics per eye, the rotation's tangent
// (Ceres EigenQuaternionManifold: half the rotation vector) and the translation.
std::vector<std::string> StereoTangentNames(const StereoFitOptions& options, int np) {
  std::vector<std::string> out;
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options.intrinsics);
  const std::vector<std::string> names = IntrinsicParamNames(options.intrinsics.model);
  for (int e = 0; e < 2 && !options.fix_intrinsics; ++e)
    for (int i = 0; i < np; ++i)
      if (std::find(fixed.begin(), fixed.end(), i) == fixed.end())
        out.push_back(std::string(kStereoEye[e]) + "." + names[i]);
  for (const char* n : {"stereo.rx", "stereo.ry", "stereo.rz", "stereo.tx", "stereo.ty", "stereo.tz"}) out.push_back(n);
  if (options.fit_board_warp)
    for (const char* n : {"stereo.board_warp_x", "stereo.board_warp_y"}) out.push_back(n);
  return out;
}

// The joint solve and its observability analysis (board poses eliminated).
Observability SolveStereo(const StereoFitOptions& options, StereoProblemData* d, ceres::Solver::Summary* summary) {
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  PoseManifold pose_manifold;
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options.intrinsics);
  std::unique_ptr<ceres::SubsetManifold> subset[2];
  for (int e = 0; e < 2; ++e) {
    problem.AddParameterBlock(d->cam[e].data(), d->np);
    if (!fixed.empty()) {
      subset[e] = std::make_unique<ceres::SubsetManifold>(d->np, fixed);
      problem.SetManifold(d->cam[e].data(), subset[e].get());
    }
  }
  problem.AddParameterBlock(d->ext.data(), 7, &pose_manifold);
  for (auto& p : d->poses) problem.AddParameterBlock(p.data(), 7, &pose_manifold);
  const bool tie = options.intrinsics.fix_aspect_ratio;
  const models::DistortionModel model = options.intrinsics.model;
  for (const StereoObs& o : d->obs) {
    ceres::LossFunction* loss = nullptr;
    if (options.intrinsics.loss == RobustLoss::kHuber) loss = new ceres::HuberLoss(options.intrinsics.loss_scale_sigma);
    if (options.intrinsics.loss == RobustLoss::kCauchy)
      loss = new ceres::CauchyLoss(options.intrinsics.loss_scale_sigma);
    const double inv = 1.0 / d->sigma_used[o.eye];
    const bool on_left_pose = d->pose_of_left_frame.count(o.frame) > 0;
    double* pose =
        d->poses[on_left_pose ? d->pose_of_left_frame.at(o.frame) : d->pose_of_right_only_frame.at(o.frame)].data();
    if (options.fit_board_warp && o.eye == 1 && on_left_pose) {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::WarpedStereoCornerResidual<Cam>::Create(o.pixel, o.point, d->span, inv, tie);
      });
      problem.AddResidualBlock(c, loss, d->cam[1].data(), d->ext.data(), pose, d->warp.data());
    } else if (options.fit_board_warp) {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::WarpedCornerResidual<Cam>::Create(o.pixel, o.point, d->span, inv, tie);
      });
      problem.AddResidualBlock(c, loss, d->cam[o.eye].data(), pose, d->warp.data());
    } else if (o.eye == 1 && on_left_pose) {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::StereoCornerResidual<Cam>::Create(o.pixel, o.point, inv, tie);
      });
      problem.AddResidualBlock(c, loss, d->cam[1].data(), d->ext.data(), pose);
    } else {
      ceres::CostFunction* c = models::VisitCameraModel(
          model, [&]<typename Cam>() { return internal::CornerResidual<Cam>::Create(o.pixel, o.point, inv, tie); });
      problem.AddResidualBlock(c, loss, d->cam[o.eye].data(), pose);
    }
  }
  if (options.fix_intrinsics) {
    problem.SetParameterBlockConstant(d->cam[0].data());
    problem.SetParameterBlockConstant(d->cam[1].data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.intrinsics.solver_tolerance;
  so.parameter_tolerance = options.intrinsics.solver_tolerance;
  so.gradient_tolerance = options.intrinsics.solver_tolerance;
  ceres::Solve(so, &problem, summary);
  if (!options.intrinsics.compute_covariance) {
    Observability none;
    none.message = "not computed (compute_covariance off)";
    return none;
  }
  std::vector<double*> locals;
  for (auto& p : d->poses) locals.push_back(p.data());
  std::vector<double*> globals = {d->cam[0].data(), d->cam[1].data(), d->ext.data()};
  if (options.fit_board_warp) globals.push_back(d->warp.data());
  return AnalyseObservability(
      &problem, globals, locals, StereoTangentNames(options, d->np), options.intrinsics.rank_tolerance);
}

// RMS per camera and joint (pixel errors, OpenCV's definition); returns the corners per eye.
std::array<int, 2> MeasureStereoRms(const StereoProblemData& d, StereoFit* fit) {
  double sum_sq[2] = {0, 0};
  std::array<int, 2> n = {0, 0};
  for (const StereoObs& o : d.obs) {
    const bool on_left_pose = d.pose_of_left_frame.count(o.frame) > 0;
    models::Rigid3d cam_from_target = models::Rigid3d::Map(
        d.poses[on_left_pose ? d.pose_of_left_frame.at(o.frame) : d.pose_of_right_only_frame.at(o.frame)].data());
    if (o.eye == 1 && on_left_pose) cam_from_target = fit->right_from_left * cam_from_target;
    const Eigen::Vector3d p = cam_from_target * WarpedPoint(d.warp.data(), o.point, d.span);
    double px[2] = {kNaN, kNaN};
    fit->cameras[o.eye].Project(p.data(), px);
    sum_sq[o.eye] += (Eigen::Vector2d(px[0], px[1]) - o.pixel).squaredNorm();
    ++n[o.eye];
  }
  for (int e = 0; e < 2; ++e) fit->rms_px[e] = std::sqrt(sum_sq[e] / std::max(1, n[e]));
  fit->rms_joint_px = std::sqrt((sum_sq[0] + sum_sq[1]) / std::max(1, n[0] + n[1]));
  return n;
}

// Covariance of [left params, right params, rotation vector, T] = G C G^T with G the Jacobian
// of the reported parameters by the tangent coordinates, sigmas, and what is not determined.
void ReportStereoCovariance(const Observability& obs, double scale, const StereoFitOptions& options, StereoFit* fit) {
  const models::DistortionModel model = options.intrinsics.model;
  const int np = int(fit->cameras[0].params.size());
  const bool tie = options.intrinsics.fix_aspect_ratio;
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options.intrinsics);
  const std::vector<std::string> names = IntrinsicParamNames(model);
  const int ng = 2 * np + 6;
  for (int e = 0; e < 2; ++e)
    for (const auto& nm : names) fit->param_names.push_back(std::string(kStereoEye[e]) + "." + nm);
  for (const char* nm : {"stereo.rx", "stereo.ry", "stereo.rz", "stereo.tx", "stereo.ty", "stereo.tz"})
    fit->param_names.push_back(nm);
  std::vector<int> free_idx;
  for (int e = 0; e < 2 && !options.fix_intrinsics; ++e)
    for (int i = 0; i < np; ++i)
      if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free_idx.push_back(e * np + i);
  const int tangent = int(free_idx.size()) + 6;
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(ng, tangent);
  for (size_t k = 0; k < free_idx.size(); ++k) g(free_idx[k], k) = 1.0;
  if (tie && !options.fix_intrinsics)
    for (int e = 0; e < 2; ++e) g.row(e * np + 1) = g.row(e * np + 0);
  // Extrinsic tangent [delta(3), dt(3)]: q' = Exp(delta) q with |rotation| = 2 |delta|.
  const Eigen::Vector3d r0 = RotVec(fit->right_from_left.rotation);
  const double h = 1e-7;
  for (int j = 0; j < 3; ++j) {
    Eigen::Vector3d w = Eigen::Vector3d::Zero();
    w(j) = 2 * h;  // rotation vector of the perturbation = 2 delta
    const Eigen::Quaterniond dq(Eigen::AngleAxisd(w.norm(), w.normalized()));
    g.block(2 * np, int(free_idx.size()) + j, 3, 1) = (RotVec(dq * fit->right_from_left.rotation) - r0) / h;
  }
  g.block(2 * np + 3, int(free_idx.size()) + 3, 3, 3).setIdentity();
  fit->covariance = Eigen::MatrixXd::Zero(ng, ng);
  fit->sigmas.assign(ng, kNaN);
  fit->determined.assign(ng, false);
  std::vector<std::string> reasons(ng);
  const int num_warp = options.fit_board_warp ? 2 : 0;
  fit->board_warp_fitted = options.fit_board_warp;
  for (int j = 0; j < 2; ++j) fit->board_warp_sigma[j] = num_warp ? kNaN : 0.0;
  if (obs.ok && obs.covariance.rows() == tangent + num_warp) {
    // The bow is marginalised: its rows are left out, its sigma kept apart.
    for (int j = 0; j < num_warp; ++j)
      if (obs.determined[tangent + j])
        fit->board_warp_sigma[j] = std::sqrt(scale * obs.covariance(tangent + j, tangent + j));
    Eigen::MatrixXd c = obs.covariance.topLeftCorner(tangent, tangent) * scale;
    for (int k = 0; k < tangent; ++k) {
      if (obs.determined[k]) continue;
      c.row(k).setZero();
      c.col(k).setZero();
      for (int i = 0; i < ng; ++i)
        if (g(i, k) != 0) reasons[i] = obs.reasons[k];
    }
    fit->covariance = g * c * g.transpose();
  } else {
    for (int i = 0; i < ng; ++i) reasons[i] = "covariance failed: " + obs.message;
  }
  for (int i = 0; i < ng; ++i) {
    const std::string& full = fit->param_names[i];
    const bool is_cam = i < 2 * np;
    const std::string nm = is_cam ? names[i % np] : full;
    if (is_cam && options.fix_intrinsics) {
      fit->undetermined.push_back(full + ": fixed by option fix_intrinsics (per-eye estimate)");
      continue;
    }
    const std::string fr = is_cam ? internal::FixedReason(nm, options.intrinsics) : "";
    if (!fr.empty() && !(nm == "fy" && tie)) {
      fit->undetermined.push_back(full + ": " + fr);
      continue;
    }
    const double s = std::sqrt(fit->covariance(i, i));
    if (reasons[i].empty() && is_cam) reasons[i] = internal::SigmaTooLarge(nm, s, options.intrinsics);
    if (reasons[i].empty() && !std::isfinite(s)) reasons[i] = "no finite sigma";
    if (!reasons[i].empty()) {
      fit->undetermined.push_back(full + ": " + reasons[i]);
      continue;
    }
    fit->sigmas[i] = s;
    fit->determined[i] = true;
  }
}

// cv::stereoRectify (CALIB_ZERO_DISPARITY, alpha) and the rectified epipolar error |y_l - y_r|
// of the same corner over every corner seen by both eyes.
void Rectify(const std::vector<calib::View>& left_views,
             const std::vector<calib::View>& right_views,
             const StereoFitOptions& options,
             StereoFit* fit) {
  const cv::Mat m1 = StereoCameraMatrix(fit->cameras[0]), d1 = StereoDistCoeffs(fit->cameras[0]);
  const cv::Mat m2 = StereoCameraMatrix(fit->cameras[1]), d2 = StereoDistCoeffs(fit->cameras[1]);
  cv::Mat r, t, r1, r2, p1, p2, q;
  cv::eigen2cv(Eigen::Matrix3d(fit->right_from_left.rotation.toRotationMatrix()), r);
  cv::eigen2cv(Eigen::Vector3d(fit->right_from_left.translation), t);
  try {
    cv::stereoRectify(m1,
                      d1,
                      m2,
                      d2,
                      cv::Size(options.width, options.height),
                      r,
                      t,
                      r1,
                      r2,
                      p1,
                      p2,
                      q,
                      cv::CALIB_ZERO_DISPARITY,
                      options.rectify_alpha);
    cv::cv2eigen(r1, fit->R1);
    cv::cv2eigen(r2, fit->R2);
    cv::cv2eigen(p1, fit->P1);
    cv::cv2eigen(p2, fit->P2);
    cv::cv2eigen(q, fit->Q);
    std::vector<cv::Point2d> pl, pr;
    for (int f : fit->paired_frames) {
      std::map<int, Eigen::Vector2d> lp;
      for (const calib::View& v : left_views)
        if (v.frame_index == f)
          for (size_t i = 0; i < v.pixels.size(); ++i) lp[v.corner_ids[i]] = v.pixels[i];
      for (const calib::View& v : right_views)
        if (v.frame_index == f)
          for (size_t i = 0; i < v.pixels.size(); ++i) {
            auto it = lp.find(v.corner_ids[i]);
            if (it == lp.end()) continue;
            pl.emplace_back(it->second.x(), it->second.y());
            pr.emplace_back(v.pixels[i].x(), v.pixels[i].y());
          }
    }
    if (pl.empty()) return;
    std::vector<cv::Point2d> ul, ur;
    cv::undistortPoints(pl, ul, m1, d1, r1, p1);
    cv::undistortPoints(pr, ur, m2, d2, r2, p2);
    double sum = 0, mx = 0;
    for (size_t i = 0; i < ul.size(); ++i) {
      const double dy = std::abs(ul[i].y - ur[i].y);
      sum += dy;
      mx = std::max(mx, dy);
    }
    fit->rectified_dy_mean_px = sum / ul.size();
    fit->rectified_dy_max_px = mx;
    fit->rectified_num_corners = int(ul.size());
  } catch (const cv::Exception& e) {
    fit->undetermined.push_back(std::string("rectification: cv::stereoRectify failed: ") + e.what());
  }
}

}  // namespace

StereoFit FitStereo(const std::vector<calib::View>& left_views,
                    const std::vector<calib::View>& right_views,
                    const StereoFitOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  StereoFit fit;
  fit.length_unit = options.length_unit;
  fit.summary.problem = "stereo";
  std::string why;
  if (!options.Check(&why)) {
    fit.message = why;
    return fit;
  }
  // 1. Build: per-eye fits (initialisation and per-eye outlier rejection), pairs, blocks.
  const std::string stereo_params = "stereo R, T and the baseline";
  if (left_views.empty() || right_views.empty()) {
    fit.message =
        stereo_params + " cannot be determined: " +
        (left_views.empty() && right_views.empty()
             ? std::string("no views at all")
             : std::string("only the ") + (left_views.empty() ? "right" : "left") + " eye has views (one eye only)");
    fit.undetermined.push_back("stereo.*: one eye only");
  }
  const std::vector<calib::View>* vs[2] = {&left_views, &right_views};
  for (int e = 0; e < 2; ++e)
    if (!vs[e]->empty()) fit.per_eye[e] = FitIntrinsics(*vs[e], options.width, options.height, options.intrinsics);
  if (!fit.message.empty()) return fit;
  for (int e = 0; e < 2; ++e) {
    if (fit.per_eye[e].ok) continue;
    fit.message = stereo_params + " cannot be determined: the " + kStereoEye[e] +
                  " camera's intrinsics could not be fitted: " + fit.per_eye[e].message;
    fit.undetermined.push_back(std::string("stereo.*: ") + kStereoEye[e] + " intrinsics not determined");
    return fit;
  }
  std::map<int, int> left_of_frame, right_of_frame;
  for (size_t i = 0; i < fit.per_eye[0].frame_indices.size(); ++i)
    left_of_frame[fit.per_eye[0].frame_indices[i]] = int(i);
  for (size_t i = 0; i < fit.per_eye[1].frame_indices.size(); ++i)
    right_of_frame[fit.per_eye[1].frame_indices[i]] = int(i);
  for (const auto& [f, i] : left_of_frame)
    if (right_of_frame.count(f)) fit.paired_frames.push_back(f);
  if (fit.paired_frames.empty()) {
    fit.message = stereo_params +
                  " cannot be determined: no frame has the board detected in both eyes (pairs are "
                  "matched by frame_index)";
    fit.undetermined.push_back("stereo.*: no common frames");
    return fit;
  }
  StereoProblemData d =
      BuildStereoData(vs, InitialRightFromLeft(fit, left_of_frame, right_of_frame), left_of_frame, options, &fit);

  // 2. Solve, 3. observability.
  ceres::Solver::Summary summary;
  const Observability obs = SolveStereo(options, &d, &summary);
  fit.summary = internal::ToSolveSummary("stereo", &summary);
  if (options.intrinsics.fix_aspect_ratio) {
    d.cam[0][1] = d.cam[0][0];
    d.cam[1][1] = d.cam[1][0];
  }
  for (int e = 0; e < 2; ++e) {
    fit.cameras[e] = fit.per_eye[e].camera;
    fit.cameras[e].params = d.cam[e];
  }
  fit.right_from_left = models::Rigid3d::Map(d.ext.data());
  for (int j = 0; j < 2; ++j) fit.board_warp[j] = d.warp[j];

  // 4. Outputs. chi^2 / dof of the whitened residuals is the posterior noise scale when sigma
  // was estimated.
  const std::array<int, 2> n = MeasureStereoRms(d, &fit);
  fit.summary.rms_px = fit.rms_joint_px;
  fit.summary.num_outliers = int(fit.rejected.size());
  const int num_fixed = int(internal::FixedIntrinsicIndices(options.intrinsics).size());
  const int num_free = (options.fix_intrinsics ? 0 : 2 * (d.np - num_fixed)) + 6 + 6 * int(d.poses.size()) +
                       (options.fit_board_warp ? 2 : 0);
  const int dof = 2 * (n[0] + n[1]) - num_free;
  double scale = 1.0;
  if (options.intrinsics.corner_sigma_px <= 0 && dof > 0) scale = 2.0 * summary.final_cost / dof;
  for (int e = 0; e < 2; ++e) fit.corner_sigma_px[e] = d.sigma_used[e] * std::sqrt(scale);
  ReportStereoCovariance(obs, scale, options, &fit);
  Rectify(left_views, right_views, options, &fit);
  fit.ok = true;
  std::ostringstream msg;
  msg << fit.paired_frames.size() << " pairs, RMS left " << StereoFmt(fit.rms_px[0]) << " right "
      << StereoFmt(fit.rms_px[1]) << " joint " << StereoFmt(fit.rms_joint_px) << " px, baseline "
      << StereoFmt(fit.right_from_left.translation.norm(), 6) << " " << options.length_unit << ", rectified |dy| mean "
      << StereoFmt(fit.rectified_dy_mean_px) << " max " << StereoFmt(fit.rectified_dy_max_px) << " px";
  fit.message = msg.str();
  bool ext_ok = true;
  for (int i = 2 * d.np; i < 2 * d.np + 6; ++i) ext_ok = ext_ok && fit.determined[i];
  fit.summary.usable = fit.summary.usable && ext_ok;
  fit.summary.message = fit.message + " | " + fit.summary.message;
  fit.summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return fit;
}

}  // namespace owlcal::fitting
