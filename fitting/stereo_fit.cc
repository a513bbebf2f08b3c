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

#include "fitting/covariance_marginal.h"
#include "fitting/intrinsics_residual.h"

namespace owlcal::fitting {
namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr const char* kEye[2] = {"left", "right"};

std::string Fmt(double v, int prec = 4) {
  std::ostringstream s;
  s.precision(prec);
  s << v;
  return s.str();
}

Eigen::Vector3d RotVec(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd aa(q.normalized());
  return aa.angle() * aa.axis();
}

cv::Mat CameraMatrix(const models::CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.params[0], 0, c.params[2], 0, c.params[1], c.params[3], 0, 0, 1);
}
cv::Mat DistCoeffs(const models::CameraIntrinsics& c) {
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
    return fail("rectify_alpha must be -1 or 0..1, got " + Fmt(rectify_alpha));
  if (max_iterations < 1) return fail("max_iterations must be >= 1, got " + std::to_string(max_iterations));
  return true;
}

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
  const std::string stereo_params = "stereo R, T and the baseline";
  if (left_views.empty() || right_views.empty()) {
    fit.message = stereo_params + " cannot be determined: " +
                  (left_views.empty() && right_views.empty() ? std::string("no views at all")
                                                             : std::string("only the ") +
                                                                   (left_views.empty() ? "right" : "left") +
                                                                   " eye has views (one eye only)");
    fit.undetermined.push_back("stereo.*: one eye only");
  }
  const std::vector<calib::View>* vs[2] = {&left_views, &right_views};
  for (int e = 0; e < 2; ++e)
    if (!vs[e]->empty()) fit.per_eye[e] = FitIntrinsics(*vs[e], options.width, options.height, options.intrinsics);
  if (!fit.message.empty()) return fit;
  for (int e = 0; e < 2; ++e) {
    if (!fit.per_eye[e].ok) {
      fit.message = stereo_params + " cannot be determined: the " + kEye[e] +
                    " camera's intrinsics could not be fitted: " + fit.per_eye[e].message;
      fit.undetermined.push_back(std::string("stereo.*: ") + kEye[e] + " intrinsics not determined");
      return fit;
    }
  }
  const std::vector<int>& fl = fit.per_eye[0].frame_indices;
  const std::vector<int>& fr = fit.per_eye[1].frame_indices;
  std::map<int, int> left_of_frame, right_of_frame;
  for (size_t i = 0; i < fl.size(); ++i) left_of_frame[fl[i]] = int(i);
  for (size_t i = 0; i < fr.size(); ++i) right_of_frame[fr[i]] = int(i);
  for (const auto& [f, i] : left_of_frame)
    if (right_of_frame.count(f)) fit.paired_frames.push_back(f);
  if (fit.paired_frames.empty()) {
    fit.message = stereo_params + " cannot be determined: no frame has the board detected in both eyes (pairs are "
                                  "matched by frame_index)";
    fit.undetermined.push_back("stereo.*: no common frames");
    return fit;
  }

  // Initial right_from_left: sign-aligned quaternion mean and median translation over pairs.
  Eigen::Vector4d qsum = Eigen::Vector4d::Zero();
  std::vector<double> tx, ty, tz;
  Eigen::Quaterniond qref = Eigen::Quaterniond::Identity();
  for (size_t k = 0; k < fit.paired_frames.size(); ++k) {
    const int f = fit.paired_frames[k];
    const models::Rigid3d rl = fit.per_eye[1].cam_from_target[right_of_frame[f]] *
                               fit.per_eye[0].cam_from_target[left_of_frame[f]].Inverse();
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
  models::Rigid3d init(q0, Eigen::Vector3d(median(tx), median(ty), median(tz)));

  // Parameter blocks.
  const models::DistortionModel model = options.intrinsics.model;
  const int np = 4 + fit.per_eye[0].camera.NumDistortion();
  std::vector<double> cam[2] = {fit.per_eye[0].camera.params, fit.per_eye[1].camera.params};
  std::array<double, 7> ext;
  init.ToArray(ext.data());
  // Board poses: one per left-eye frame (left cam_from_target), one per right-only frame.
  std::vector<std::array<double, 7>> poses;
  std::map<int, int> pose_of_left_frame, pose_of_right_only_frame;
  for (size_t i = 0; i < fl.size(); ++i) {
    std::array<double, 7> a;
    fit.per_eye[0].cam_from_target[i].ToArray(a.data());
    pose_of_left_frame[fl[i]] = int(poses.size());
    poses.push_back(a);
  }
  for (size_t i = 0; i < fr.size(); ++i) {
    if (left_of_frame.count(fr[i])) continue;
    std::array<double, 7> a;
    fit.per_eye[1].cam_from_target[i].ToArray(a.data());
    pose_of_right_only_frame[fr[i]] = int(poses.size());
    poses.push_back(a);
  }
  for (const auto& [f, i] : pose_of_left_frame) fit.frame_indices.push_back(f);
  for (const auto& [f, i] : pose_of_right_only_frame) fit.frame_indices.push_back(f);

  // Observations (minus each eye's rejected outliers).
  struct Obs {
    int eye, frame, corner;
    Eigen::Vector2d pixel;
    Eigen::Vector3d point;
  };
  std::vector<Obs> obs;
  for (int e = 0; e < 2; ++e) {
    std::set<std::pair<int, int>> rejected;
    for (const auto& r : fit.per_eye[e].rejected) {
      rejected.insert({r.frame_index, r.corner_id});
      fit.rejected.push_back(r);
    }
    const std::set<int> used_frames(fit.per_eye[e].frame_indices.begin(), fit.per_eye[e].frame_indices.end());
    for (const calib::View& v : *vs[e]) {
      if (!used_frames.count(v.frame_index)) continue;
      for (size_t i = 0; i < v.pixels.size(); ++i) {
        if (rejected.count({v.frame_index, v.corner_ids[i]})) continue;
        obs.push_back({e, v.frame_index, v.corner_ids[i], v.pixels[i], v.points_in_target[i]});
      }
    }
  }
  // One pooled corner sigma for both eyes, so the joint solve minimises the plain sum of squared
  // pixel errors (stereoCalibrate's objective); it is re-estimated from the joint residuals.
  double sigma_used[2];
  {
    int ne[2] = {0, 0};
    for (const Obs& o : obs) ++ne[o.eye];
    const double s0 = fit.per_eye[0].corner_sigma_px, s1 = fit.per_eye[1].corner_sigma_px;
    const double pooled = std::sqrt((s0 * s0 * ne[0] + s1 * s1 * ne[1]) / std::max(1, ne[0] + ne[1]));
    for (int e = 0; e < 2; ++e)
      sigma_used[e] = options.intrinsics.corner_sigma_px > 0 ? options.intrinsics.corner_sigma_px
                                                             : std::max(1e-4, std::isfinite(pooled) ? pooled : 1.0);
  }

  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  PoseManifold pose_manifold;
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options.intrinsics);
  std::unique_ptr<ceres::SubsetManifold> subset[2];
  for (int e = 0; e < 2; ++e) {
    problem.AddParameterBlock(cam[e].data(), np);
    if (!fixed.empty()) {
      subset[e] = std::make_unique<ceres::SubsetManifold>(np, fixed);
      problem.SetManifold(cam[e].data(), subset[e].get());
    }
  }
  problem.AddParameterBlock(ext.data(), 7, &pose_manifold);
  for (auto& p : poses) problem.AddParameterBlock(p.data(), 7, &pose_manifold);
  const bool tie = options.intrinsics.fix_aspect_ratio;
  for (const Obs& o : obs) {
    ceres::LossFunction* loss = nullptr;
    if (options.intrinsics.loss == RobustLoss::kHuber) loss = new ceres::HuberLoss(options.intrinsics.loss_scale_sigma);
    if (options.intrinsics.loss == RobustLoss::kCauchy) loss = new ceres::CauchyLoss(options.intrinsics.loss_scale_sigma);
    const double inv = 1.0 / sigma_used[o.eye];
    if (o.eye == 0) {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::CornerResidual<Cam>::Create(o.pixel, o.point, inv, tie);
      });
      problem.AddResidualBlock(c, loss, cam[0].data(), poses[pose_of_left_frame.at(o.frame)].data());
    } else if (pose_of_left_frame.count(o.frame)) {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::StereoCornerResidual<Cam>::Create(o.pixel, o.point, inv, tie);
      });
      problem.AddResidualBlock(c, loss, cam[1].data(), ext.data(), poses[pose_of_left_frame.at(o.frame)].data());
    } else {
      ceres::CostFunction* c = models::VisitCameraModel(model, [&]<typename Cam>() {
        return internal::CornerResidual<Cam>::Create(o.pixel, o.point, inv, tie);
      });
      problem.AddResidualBlock(c, loss, cam[1].data(), poses[pose_of_right_only_frame.at(o.frame)].data());
    }
  }
  if (options.fix_intrinsics) {
    problem.SetParameterBlockConstant(cam[0].data());
    problem.SetParameterBlockConstant(cam[1].data());
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.gradient_tolerance = 1e-12;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  fit.summary = internal::ToSolveSummary("stereo", &summary);
  if (tie) {
    cam[0][1] = cam[0][0];
    cam[1][1] = cam[1][0];
  }
  for (int e = 0; e < 2; ++e) {
    fit.cameras[e] = fit.per_eye[e].camera;
    fit.cameras[e].params = cam[e];
  }
  fit.right_from_left = models::Rigid3d::Map(ext.data());

  // RMS per camera and joint (pixel errors, OpenCV's definition).
  double sum_sq[2] = {0, 0};
  int n[2] = {0, 0};
  for (const Obs& o : obs) {
    const bool on_left_pose = pose_of_left_frame.count(o.frame) > 0;
    models::Rigid3d cam_from_target = models::Rigid3d::Map(
        poses[on_left_pose ? pose_of_left_frame.at(o.frame) : pose_of_right_only_frame.at(o.frame)].data());
    if (o.eye == 1 && pose_of_left_frame.count(o.frame)) cam_from_target = fit.right_from_left * cam_from_target;
    const Eigen::Vector3d p = cam_from_target * o.point;
    double px[2] = {kNaN, kNaN};
    fit.cameras[o.eye].Project(p.data(), px);
    sum_sq[o.eye] += (Eigen::Vector2d(px[0], px[1]) - o.pixel).squaredNorm();
    ++n[o.eye];
  }
  for (int e = 0; e < 2; ++e) fit.rms_px[e] = std::sqrt(sum_sq[e] / std::max(1, n[e]));
  fit.rms_joint_px = std::sqrt((sum_sq[0] + sum_sq[1]) / std::max(1, n[0] + n[1]));
  fit.summary.rms_px = fit.rms_joint_px;
  fit.summary.num_outliers = int(fit.rejected.size());

  // Covariance: globals [left cam, right cam, ext], poses marginalised.
  std::vector<double*> locals;
  for (auto& p : poses) locals.push_back(p.data());
  const MarginalCovariance mc = ComputeMarginalCovariance(&problem, {cam[0].data(), cam[1].data(), ext.data()}, locals);
  // chi^2 / dof of the whitened residuals: the posterior noise scale when sigma was estimated.
  const int num_free = (options.fix_intrinsics ? 0 : 2 * (np - int(fixed.size()))) + 6 + 6 * int(poses.size());
  const int dof = 2 * (n[0] + n[1]) - num_free;
  double scale = 1.0;
  if (options.intrinsics.corner_sigma_px <= 0 && dof > 0) scale = 2.0 * summary.final_cost / dof;
  for (int e = 0; e < 2; ++e) fit.corner_sigma_px[e] = sigma_used[e] * std::sqrt(scale);

  const std::vector<std::string> names = IntrinsicParamNames(model);
  const int ng = 2 * np + 6;
  for (int e = 0; e < 2; ++e)
    for (const auto& nm : names) fit.param_names.push_back(std::string(kEye[e]) + "." + nm);
  for (const char* nm : {"stereo.rx", "stereo.ry", "stereo.rz", "stereo.tx", "stereo.ty", "stereo.tz"})
    fit.param_names.push_back(nm);
  // Tangent -> global parameter Jacobian G (ng x tangent size), then covariance = G C G^T.
  int tangent = 0;
  std::vector<int> free_idx;
  for (int e = 0; e < 2; ++e) {
    if (options.fix_intrinsics) continue;
    for (int i = 0; i < np; ++i)
      if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free_idx.push_back(e * np + i);
  }
  tangent = int(free_idx.size()) + 6;
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(ng, tangent);
  for (size_t k = 0; k < free_idx.size(); ++k) G(free_idx[k], k) = 1.0;
  if (tie && !options.fix_intrinsics) {
    for (int e = 0; e < 2; ++e) G.row(e * np + 1) = G.row(e * np + 0);
  }
  // Extrinsic tangent [delta(3), dt(3)]: q' = Exp(delta) q with |rotation| = 2 |delta|.
  {
    const Eigen::Vector3d r0 = RotVec(fit.right_from_left.rotation);
    const double h = 1e-7;
    for (int j = 0; j < 3; ++j) {
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      w(j) = 2 * h;  // rotation vector of the perturbation = 2 delta
      const Eigen::Quaterniond dq(Eigen::AngleAxisd(w.norm(), w.normalized()));
      const Eigen::Vector3d r1 = RotVec(dq * fit.right_from_left.rotation);
      G.block(2 * np, int(free_idx.size()) + j, 3, 1) = (r1 - r0) / h;
    }
    G.block(2 * np + 3, int(free_idx.size()) + 3, 3, 3).setIdentity();
  }
  fit.covariance = Eigen::MatrixXd::Zero(ng, ng);
  fit.sigmas.assign(ng, kNaN);
  fit.determined.assign(ng, false);
  std::vector<std::string> reasons(ng);
  if (mc.ok && mc.covariance.rows() == tangent) {
    Eigen::MatrixXd C = mc.covariance * scale;
    std::vector<bool> tangent_ok = mc.determined;
    for (int k = 0; k < tangent; ++k)
      if (!tangent_ok[k]) {
        C.row(k).setZero();
        C.col(k).setZero();
      }
    fit.covariance = G * C * G.transpose();
    for (int k = 0; k < tangent; ++k)
      if (!tangent_ok[k])
        for (int i = 0; i < ng; ++i)
          if (G(i, k) != 0) reasons[i] = mc.reasons[k];
  } else {
    for (int i = 0; i < ng; ++i) reasons[i] = "covariance failed: " + mc.message;
  }
  for (int i = 0; i < ng; ++i) {
    const std::string& full = fit.param_names[i];
    const bool is_cam = i < 2 * np;
    const std::string nm = is_cam ? names[i % np] : full;
    if (is_cam && options.fix_intrinsics) {
      fit.undetermined.push_back(full + ": fixed by option fix_intrinsics (per-eye estimate)");
      continue;
    }
    if (is_cam) {
      const std::string fr = internal::FixedReason(nm, options.intrinsics);
      if (!fr.empty() && !(nm == "fy" && tie)) {
        fit.undetermined.push_back(full + ": " + fr);
        continue;
      }
    }
    const double s = std::sqrt(fit.covariance(i, i));
    if (reasons[i].empty() && is_cam) reasons[i] = internal::SigmaTooLarge(nm, s, options.intrinsics);
    if (reasons[i].empty() && !std::isfinite(s)) reasons[i] = "no finite sigma";
    if (!reasons[i].empty()) {
      fit.undetermined.push_back(full + ": " + reasons[i]);
      continue;
    }
    fit.sigmas[i] = s;
    fit.determined[i] = true;
  }

  // Rectification and the rectified epipolar error.
  const cv::Mat M1 = CameraMatrix(fit.cameras[0]), D1 = DistCoeffs(fit.cameras[0]);
  const cv::Mat M2 = CameraMatrix(fit.cameras[1]), D2 = DistCoeffs(fit.cameras[1]);
  cv::Mat R, T, R1, R2, P1, P2, Q;
  cv::eigen2cv(Eigen::Matrix3d(fit.right_from_left.rotation.toRotationMatrix()), R);
  cv::eigen2cv(Eigen::Vector3d(fit.right_from_left.translation), T);
  try {
    cv::stereoRectify(M1, D1, M2, D2, cv::Size(options.width, options.height), R, T, R1, R2, P1, P2, Q,
                      cv::CALIB_ZERO_DISPARITY, options.rectify_alpha);
    cv::cv2eigen(R1, fit.R1);
    cv::cv2eigen(R2, fit.R2);
    cv::cv2eigen(P1, fit.P1);
    cv::cv2eigen(P2, fit.P2);
    cv::cv2eigen(Q, fit.Q);
    std::vector<cv::Point2d> pl, pr;
    for (int f : fit.paired_frames) {
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
    if (!pl.empty()) {
      std::vector<cv::Point2d> ul, ur;
      cv::undistortPoints(pl, ul, M1, D1, R1, P1);
      cv::undistortPoints(pr, ur, M2, D2, R2, P2);
      double sum = 0, mx = 0;
      for (size_t i = 0; i < ul.size(); ++i) {
        const double dy = std::abs(ul[i].y - ur[i].y);
        sum += dy;
        mx = std::max(mx, dy);
      }
      fit.rectified_dy_mean_px = sum / ul.size();
      fit.rectified_dy_max_px = mx;
      fit.rectified_num_corners = int(ul.size());
    }
  } catch (const cv::Exception& e) {
    fit.undetermined.push_back(std::string("rectification: cv::stereoRectify failed: ") + e.what());
  }

  fit.ok = true;
  std::ostringstream msg;
  msg << fit.paired_frames.size() << " pairs, RMS left " << Fmt(fit.rms_px[0]) << " right " << Fmt(fit.rms_px[1])
      << " joint " << Fmt(fit.rms_joint_px) << " px, baseline " << Fmt(fit.right_from_left.translation.norm(), 6) << " "
      << options.length_unit << ", rectified |dy| mean " << Fmt(fit.rectified_dy_mean_px) << " max "
      << Fmt(fit.rectified_dy_max_px) << " px";
  fit.message = msg.str();
  bool ext_ok = true;
  for (int i = 2 * np; i < ng; ++i) ext_ok = ext_ok && fit.determined[i];
  fit.summary.usable = fit.summary.usable && ext_ok;
  fit.summary.message = fit.message + " | " + fit.summary.message;
  fit.summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return fit;
}

void AppendStereoToResult(const StereoFit& fit, CalibrationResult* result) {
  if (!fit.ok) {
    for (int e = 0; e < 2; ++e)
      if (fit.per_eye[e].ok || !fit.per_eye[e].message.empty()) AppendIntrinsicsToResult(fit.per_eye[e], kEye[e], result);
    result->warnings.push_back("stereo: " + fit.message);
    SolveSummary s = fit.summary;
    s.problem = "stereo";
    s.message = fit.message;
    s.usable = false;
    result->summaries.push_back(s);
    const bool metres = fit.length_unit == "m";
    const std::string unit = metres ? "mm" : fit.length_unit + "s";
    result->Set({metres ? "stereo.baseline_mm" : "stereo.baseline_" + unit, kNaN, kNaN, unit, std::nullopt, false,
                 fit.message});
    return;
  }
  const int np = int(fit.cameras[0].params.size());
  const std::vector<std::string> names = IntrinsicParamNames(fit.cameras[0].model);
  auto note_of = [&](const std::string& full) {
    for (const auto& u : fit.undetermined)
      if (u.rfind(full + ":", 0) == 0) return u.substr(full.size() + 2);
    return std::string();
  };
  for (int e = 0; e < 2; ++e) {
    result->cameras[e] = fit.cameras[e];
    for (int i = 0; i < np; ++i) {
      const int k = e * np + i;
      result->Set({fit.param_names[k], fit.cameras[e].params[i], fit.sigmas[k], IntrinsicParamUnit(names[i]),
                   std::nullopt, bool(fit.determined[k]), note_of(fit.param_names[k])});
    }
  }
  const bool metres = fit.length_unit == "m";
  const double f = metres ? 1000.0 : 1.0;
  const std::string unit = metres ? "mm" : fit.length_unit + "s";
  const int ro = 2 * np, to = 2 * np + 3;
  const Eigen::Vector3d rv = RotVec(fit.right_from_left.rotation);
  const Eigen::Vector3d t = fit.right_from_left.translation;
  const char* rn[3] = {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"};
  const char* tn[3] = {"stereo.tx", "stereo.ty", "stereo.tz"};
  for (int j = 0; j < 3; ++j) {
    result->Set({rn[j], rv(j) * 180 / M_PI, fit.sigmas[ro + j] * 180 / M_PI, "deg", std::nullopt,
                 bool(fit.determined[ro + j]), note_of(fit.param_names[ro + j])});
    result->Set({tn[j], t(j) * f, fit.sigmas[to + j] * f, unit, std::nullopt, bool(fit.determined[to + j]),
                 note_of(fit.param_names[to + j])});
  }
  // Baseline |T| and its sigma by first-order propagation.
  const double b = t.norm();
  const Eigen::Vector3d g = t / b;
  const Eigen::Matrix3d Ct = fit.covariance.block(to, to, 3, 3);
  const bool t_ok = fit.determined[to] && fit.determined[to + 1] && fit.determined[to + 2];
  result->Set({metres ? "stereo.baseline_mm" : "stereo.baseline_" + unit, b * f,
               t_ok ? std::sqrt(g.dot(Ct * g)) * f : kNaN, unit, std::nullopt, t_ok,
               t_ok ? "" : "translation not determined"});
  for (const auto& u : fit.undetermined) result->warnings.push_back(u);
  if (!metres)
    result->warnings.push_back("stereo translation is in " + unit + " (target unit '" + fit.length_unit +
                               "'), not metres; result stereo covariance is in that unit");
  StereoEstimate est;
  est.right_from_left = fit.right_from_left;
  est.covariance.setZero();
  const Eigen::MatrixXd& C = fit.covariance;
  for (int a = 0; a < 6; ++a)
    for (int c = 0; c < 6; ++c) est.covariance(a, c) = C(ro + a, ro + c);
  if (metres && C.rows() == int(fit.param_names.size()) && C.cols() == C.rows()) {
    est.full_names = fit.param_names;
    est.full_covariance = C;
  }
  result->stereo = est;
  SolveSummary s = fit.summary;
  s.problem = "stereo";
  result->summaries.push_back(s);
  for (int e = 0; e < 2; ++e) {
    SolveSummary pe = fit.per_eye[e].summary;
    pe.problem = std::string("intrinsics.") + kEye[e] + " (initialisation)";
    result->summaries.push_back(pe);
  }
  nlohmann::json d;
  d["pairs"] = fit.paired_frames;
  d["rms_px"] = {{"left", fit.rms_px[0]}, {"right", fit.rms_px[1]}, {"joint", fit.rms_joint_px}};
  d["corner_sigma_px"] = {{"left", fit.corner_sigma_px[0]}, {"right", fit.corner_sigma_px[1]}};
  d["rectified_dy_mean_px"] = fit.rectified_dy_mean_px;
  d["rectified_dy_max_px"] = fit.rectified_dy_max_px;
  d["rectified_num_corners"] = fit.rectified_num_corners;
  d["length_unit"] = fit.length_unit;
  nlohmann::json rej = nlohmann::json::array();
  for (const auto& r : fit.rejected)
    rej.push_back({{"eye", kEye[r.eye == 1 ? 1 : 0]}, {"frame", r.frame_index}, {"corner", r.corner_id}, {"residual_px", r.residual_px}});
  d["rejected"] = rej;
  result->diagnostics["stereo"] = d;
}

}  // namespace owlcal::fitting
