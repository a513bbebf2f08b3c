#include "fitting/intrinsics_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <set>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "fitting/intrinsics_residual.h"
#include "fitting/observability.h"
#include "io/number_text.h"
#include "models/units.h"

namespace owlcal::fitting {

IntrinsicsFitOptions WithModel(IntrinsicsFitOptions o, models::DistortionModel model) {
  o.model = model;
  if (model == models::DistortionModel::kOpenCv8)
    for (int k : o.rational_fix_radial)
      if (std::find(o.fix_radial.begin(), o.fix_radial.end(), k) == o.fix_radial.end()) o.fix_radial.push_back(k);
  return o;
}

namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

std::string Fmt(double v, int prec = 4) { return io::SignificantText(v, prec); }

models::Rigid3d PoseFromRvecTvec(const cv::Mat& rvec, const cv::Mat& tvec) {
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d Re;
  cv::cv2eigen(R, Re);
  Eigen::Vector3d t(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return models::Rigid3d(Eigen::Quaterniond(Re), t);
}

double AngleBetween(const models::Rigid3d& a, const models::Rigid3d& b) {
  return a.rotation.angularDistance(b.rotation);
}

}  // namespace

namespace internal {

std::vector<int> FixedIntrinsicIndices(const IntrinsicsFitOptions& o) {
  std::vector<int> fixed;
  if (o.fix_aspect_ratio) fixed.push_back(1);
  if (o.fix_principal_point) {
    fixed.push_back(2);
    fixed.push_back(3);
  }
  if (o.fix_tangential) {
    fixed.push_back(6);
    fixed.push_back(7);
  }
  const int np = int(IntrinsicParamNames(o.model).size());
  const int radial_index[7] = {-1, 4, 5, 8, 9, 10, 11};  // k1..k6 in camera.params
  for (int k = 1; k <= 6; ++k) {
    const bool held =
        (k == 3 && o.fix_k3) || std::find(o.fix_radial.begin(), o.fix_radial.end(), k) != o.fix_radial.end();
    if (held && radial_index[k] < np) fixed.push_back(radial_index[k]);
  }
  std::sort(fixed.begin(), fixed.end());
  return fixed;
}

std::string SigmaTooLarge(const std::string& name, double sigma, const IntrinsicsFitOptions& o) {
  const bool px = IntrinsicParamUnit(name) == "px";
  const double limit = px ? o.max_sigma_px : o.max_sigma_distortion;
  if (std::isfinite(sigma) && sigma <= limit) return "";
  return "sigma " + Fmt(sigma) + (px ? " px" : "") + " exceeds " + Fmt(limit) +
         " (the views do not constrain it; add views with the board tilted and near the image corners)";
}

std::string FixedReason(const std::string& name, const IntrinsicsFitOptions& o) {
  if (name == "fy" && o.fix_aspect_ratio) return "tied to fx by option fix_aspect_ratio";
  if ((name == "cx" || name == "cy") && o.fix_principal_point)
    return "fixed at the image centre by option fix_principal_point";
  if ((name == "p1" || name == "p2") && o.fix_tangential) return "fixed at 0 by option fix_tangential";
  if (name == "k3" && o.fix_k3) return "fixed at 0 by option fix_k3";
  if (name.size() == 2 && name[0] == 'k' && name[1] >= '1' && name[1] <= '6' &&
      std::find(o.fix_radial.begin(), o.fix_radial.end(), name[1] - '0') != o.fix_radial.end())
    return "fixed at 0 by option fix_radial (" + name + ")";
  return "";
}

bool IsHeldReason(const std::string& why) { return why.find(" by option ") != std::string::npos; }

SolveSummary ToSolveSummary(const std::string& problem, const void* ceres_summary) {
  const auto& s = *static_cast<const ceres::Solver::Summary*>(ceres_summary);
  SolveSummary out;
  out.problem = problem;
  out.termination = ceres::TerminationTypeToString(s.termination_type);
  out.message = s.message;
  out.initial_cost = s.initial_cost;
  out.final_cost = s.final_cost;
  out.iterations = int(s.iterations.size());
  out.time_s = s.total_time_in_seconds;
  out.num_residuals = s.num_residuals;
  out.usable = s.IsSolutionUsable();
  return out;
}

}  // namespace internal

bool IntrinsicsFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "IntrinsicsFitOptions." + m;
    return false;
  };
  if (corner_sigma_px < 0 || !std::isfinite(corner_sigma_px))
    return fail("corner_sigma_px must be >= 0 (0 = estimate), got " + Fmt(corner_sigma_px));
  if (!(loss_scale_sigma > 0)) return fail("loss_scale_sigma must be > 0, got " + Fmt(loss_scale_sigma));
  if (outlier_threshold_sigma != 0 && !(outlier_threshold_sigma >= 2))
    return fail("outlier_threshold_sigma must be 0 (off) or >= 2, got " + Fmt(outlier_threshold_sigma));
  if (min_corners_per_view < 4)
    return fail("min_corners_per_view must be >= 4, got " + std::to_string(min_corners_per_view));
  if (max_iterations < 1) return fail("max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(max_sigma_px > 0)) return fail("max_sigma_px must be > 0, got " + Fmt(max_sigma_px));
  if (!(max_sigma_distortion > 0)) return fail("max_sigma_distortion must be > 0, got " + Fmt(max_sigma_distortion));
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    return fail("rank_tolerance must be in (0, 1), got " + Fmt(rank_tolerance));
  if (!(solver_tolerance > 0 && solver_tolerance < 1e-3))
    return fail("solver_tolerance must be in (0, 1e-3), got " + Fmt(solver_tolerance));
  for (int k : fix_radial)
    if (k < 1 || k > 6) return fail("fix_radial: radial coefficient numbers are 1..6, got " + std::to_string(k));
  return true;
}

std::vector<std::string> IntrinsicParamNames(models::DistortionModel model) {
  std::vector<std::string> n = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  if (model == models::DistortionModel::kOpenCv8) n.insert(n.end(), {"k4", "k5", "k6"});
  return n;
}

std::string IntrinsicParamUnit(const std::string& name) {
  return (name == "fx" || name == "fy" || name == "cx" || name == "cy") ? "px" : "";
}

namespace {

// What the initialisation gives the solver: the views it could place, one board pose per view.
struct IntrinsicsStart {
  std::vector<double> params;                // fx fy cx cy dist... (models/camera_model.h)
  std::vector<std::array<double, 7>> poses;  // cam_from_target per used view
  std::vector<calib::View> used;
  int num_orientations = 0;  // board orientations more than 3 deg apart
};

// Per-corner pixel errors (projected - measured) per used view.
using CornerErrors = std::vector<std::vector<Eigen::Vector2d>>;

// The views with at least min_corners_per_view corners; the others are named in the fit.
std::vector<calib::View> SelectViews(const std::vector<calib::View>& views_in,
                                     const IntrinsicsFitOptions& options,
                                     IntrinsicsFit* fit) {
  std::vector<calib::View> views;
  for (const calib::View& v : views_in) {
    if (int(v.pixels.size()) >= options.min_corners_per_view) {
      views.push_back(v);
      continue;
    }
    fit->dropped_views.push_back("frame " + std::to_string(v.frame_index) + ": " + std::to_string(v.pixels.size()) +
                                 " corners < min_corners_per_view " + std::to_string(options.min_corners_per_view));
  }
  return views;
}

// Zhang's closed form (cv::initCameraMatrix2D, principal point at the image centre), then one
// solvePnP per view without distortion. nullopt (with the fit's message and undetermined list)
// when no view can be placed or the board shows one orientation only.
std::optional<IntrinsicsStart> Initialise(const std::vector<calib::View>& views,
                                          const IntrinsicsFitOptions& options,
                                          IntrinsicsFit* fit) {
  const int width = fit->camera.width, height = fit->camera.height;
  const std::string all_params = "fx, fy, cx, cy and the distortion";
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const calib::View& v : views) {
    std::vector<cv::Point3f> op;
    std::vector<cv::Point2f> ip;
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      op.emplace_back(
          float(v.points_in_target[i].x()), float(v.points_in_target[i].y()), float(v.points_in_target[i].z()));
      ip.emplace_back(float(v.pixels[i].x()), float(v.pixels[i].y()));
    }
    object_points.push_back(op);
    image_points.push_back(ip);
  }
  cv::Mat k;
  try {
    k = cv::initCameraMatrix2D(
        object_points, image_points, cv::Size(width, height), options.fix_aspect_ratio ? 1.0 : 0.0);
  } catch (const cv::Exception& e) {
    fit->message = all_params + " cannot be determined: initialisation failed (" + e.what() + ")";
    return std::nullopt;
  }
  double fx0 = k.at<double>(0, 0), fy0 = k.at<double>(1, 1);
  if (!(fx0 > 0 && fy0 > 0 && std::isfinite(fx0) && std::isfinite(fy0))) {
    fx0 = fy0 = 0.8 * std::max(width, height);  // homographies degenerate; a generic guess
  }
  IntrinsicsStart st;
  st.params.assign(4 + fit->camera.NumDistortion(), 0.0);
  st.params[0] = fx0;
  st.params[1] = options.fix_aspect_ratio ? fx0 : fy0;
  st.params[2] = (width - 1) / 2.0;
  st.params[3] = (height - 1) / 2.0;
  const cv::Mat k0 = (cv::Mat_<double>(3, 3) << st.params[0], 0, st.params[2], 0, st.params[1], st.params[3], 0, 0, 1);
  std::vector<models::Rigid3d> distinct;  // orientations more than 3 degrees apart
  for (size_t i = 0; i < views.size(); ++i) {
    cv::Mat rvec, tvec;
    bool ok = false;
    try {
      ok = cv::solvePnP(object_points[i], image_points[i], k0, cv::noArray(), rvec, tvec);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok || tvec.at<double>(2) <= 0) {
      fit->dropped_views.push_back("frame " + std::to_string(views[i].frame_index) + ": initial pose not found");
      continue;
    }
    const models::Rigid3d pose = PoseFromRvecTvec(rvec, tvec);
    std::array<double, 7> a;
    pose.ToArray(a.data());
    st.poses.push_back(a);
    st.used.push_back(views[i]);
    if (std::none_of(distinct.begin(), distinct.end(), [&](const models::Rigid3d& q) {
          return AngleBetween(pose, q) < 3.0 * M_PI / 180;
        }))
      distinct.push_back(pose);
  }
  st.num_orientations = int(distinct.size());
  if (!st.used.empty() && distinct.size() >= 2) return st;
  fit->message = all_params + " cannot be determined: " +
                 (st.used.empty() ? std::string("no view could be initialised")
                                  : std::to_string(st.used.size()) +
                                        " view(s) but all show the board in ONE orientation "
                                        "(one pose only, or the board never moved); tilt "
                                        "the board (or move the camera) between views");
  for (const auto& n : fit->param_names) fit->undetermined.push_back(n + ": board seen in one orientation only");
  return std::nullopt;
}

// One Ceres solve over the inlier corners, whitened by sigma_px, with the robust loss when
// asked; with want_observability, the analysis of fitting/observability.h (poses eliminated).
Observability Solve(const IntrinsicsFitOptions& options,
                    double sigma_px,
                    bool robust,
                    const std::vector<std::vector<bool>>& inlier,
                    bool want_observability,
                    const std::vector<std::string>& param_names,
                    IntrinsicsStart* st,
                    ceres::Solver::Summary* summary) {
  const int np = int(st->params.size());
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options);
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  PoseManifold pose_manifold;
  std::unique_ptr<ceres::SubsetManifold> subset;
  problem.AddParameterBlock(st->params.data(), np);
  if (!fixed.empty()) {
    subset = std::make_unique<ceres::SubsetManifold>(np, fixed);
    problem.SetManifold(st->params.data(), subset.get());
  }
  for (size_t v = 0; v < st->used.size(); ++v) {
    problem.AddParameterBlock(st->poses[v].data(), 7, &pose_manifold);
    for (size_t i = 0; i < st->used[v].pixels.size(); ++i) {
      if (!inlier[v][i]) continue;
      ceres::CostFunction* cost = models::VisitCameraModel(options.model, [&]<typename Cam>() {
        return internal::CornerResidual<Cam>::Create(
            st->used[v].pixels[i], st->used[v].points_in_target[i], 1.0 / sigma_px, options.fix_aspect_ratio);
      });
      ceres::LossFunction* loss = nullptr;
      if (robust && options.loss == RobustLoss::kCauchy) loss = new ceres::CauchyLoss(options.loss_scale_sigma);
      if (robust && options.loss == RobustLoss::kHuber) loss = new ceres::HuberLoss(options.loss_scale_sigma);
      problem.AddResidualBlock(cost, loss, st->params.data(), st->poses[v].data());
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_SCHUR;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.solver_tolerance;
  so.parameter_tolerance = options.solver_tolerance;
  so.gradient_tolerance = options.solver_tolerance;
  so.num_threads = 1;
  ceres::Solve(so, &problem, summary);
  if (!want_observability) return {};
  std::vector<double*> locals;
  for (auto& p : st->poses) locals.push_back(p.data());
  std::vector<std::string> free_names;
  for (int i = 0; i < np; ++i)
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free_names.push_back(param_names[i]);
  return AnalyseObservability(&problem, {st->params.data()}, locals, free_names, options.rank_tolerance);
}

CornerErrors Residuals(const models::CameraIntrinsics& camera, const IntrinsicsStart& st, bool fix_aspect_ratio) {
  CornerErrors r(st.used.size());
  models::CameraIntrinsics cam = camera;
  cam.params = st.params;
  if (fix_aspect_ratio) cam.params[1] = cam.params[0];
  for (size_t v = 0; v < st.used.size(); ++v) {
    const models::Rigid3d pose = models::Rigid3d::Map(st.poses[v].data());
    for (size_t i = 0; i < st.used[v].pixels.size(); ++i) {
      const Eigen::Vector3d p = pose * st.used[v].points_in_target[i];
      double px[2] = {kNaN, kNaN};
      cam.Project(p.data(), px);
      r[v].push_back(Eigen::Vector2d(px[0], px[1]) - st.used[v].pixels[i]);
    }
  }
  return r;
}

// The corner sigma (given, or 1.4826 x the median absolute residual component) and the corners
// beyond outlier_threshold_sigma of it, marked and recorded as rejected.
double RejectOutliers(const CornerErrors& r,
                      const IntrinsicsStart& st,
                      const IntrinsicsFitOptions& options,
                      std::vector<std::vector<bool>>* inlier,
                      IntrinsicsFit* fit) {
  std::vector<double> comps;
  for (const auto& rv : r)
    for (const auto& e : rv) {
      comps.push_back(std::abs(e.x()));
      comps.push_back(std::abs(e.y()));
    }
  std::nth_element(comps.begin(), comps.begin() + comps.size() / 2, comps.end());
  const double sigma_mad = std::max(1e-4, 1.4826 * comps[comps.size() / 2]);
  const double sigma_used = options.corner_sigma_px > 0 ? options.corner_sigma_px : sigma_mad;
  if (options.outlier_threshold_sigma <= 0) return sigma_used;
  for (size_t v = 0; v < st.used.size(); ++v)
    for (size_t i = 0; i < r[v].size(); ++i) {
      const double e = r[v][i].norm();
      if (std::isfinite(e) && e <= options.outlier_threshold_sigma * sigma_used) continue;
      (*inlier)[v][i] = false;
      fit->rejected.push_back({st.used[v].frame_index, st.used[v].eye, st.used[v].corner_ids[i], e});
    }
  return sigma_used;
}

// RMS (OpenCV's definition: sqrt(sum |e|^2 / corners)) over inliers, per view and overall; the
// views' frames and poses. Returns the sum of squared errors and counts the corners.
double MeasureRms(const CornerErrors& r,
                  const std::vector<std::vector<bool>>& inlier,
                  const IntrinsicsStart& st,
                  int* num_corners,
                  IntrinsicsFit* fit) {
  double sum_sq = 0;
  int n = 0;
  for (size_t v = 0; v < st.used.size(); ++v) {
    double sv = 0;
    int nv = 0;
    for (size_t i = 0; i < r[v].size(); ++i) {
      if (!inlier[v][i]) continue;
      sv += r[v][i].squaredNorm();
      ++nv;
    }
    fit->view_rms_px.push_back(nv ? std::sqrt(sv / nv) : kNaN);
    fit->frame_indices.push_back(st.used[v].frame_index);
    fit->cam_from_target.push_back(models::Rigid3d::Map(st.poses[v].data()));
    sum_sq += sv;
    n += nv;
  }
  fit->rms_px = std::sqrt(sum_sq / std::max(1, n));
  *num_corners = n;
  return sum_sq;
}

// Covariance in the full parameter space (scaled by (sigma_hat / sigma_used)^2), sigmas, and
// what is not determined: held by an option, rejected by the observability rule, or with a
// sigma too large to mean anything.
void ReportCovariance(
    const Observability& obs, double scale, int dof, const IntrinsicsFitOptions& options, IntrinsicsFit* fit) {
  const int np = int(fit->param_names.size());
  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options);
  fit->covariance = Eigen::MatrixXd::Zero(np, np);
  fit->sigmas.assign(np, kNaN);
  fit->determined.assign(np, false);
  std::vector<int> free_idx;
  for (int i = 0; i < np; ++i)
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free_idx.push_back(i);
  std::vector<std::string> reasons(np);
  if (!obs.ok || dof <= 0 || !std::isfinite(scale)) {
    for (int i : free_idx)
      reasons[i] = dof <= 0 ? "more parameters than measurements" : "covariance failed: " + obs.message;
  } else {
    for (size_t a = 0; a < free_idx.size(); ++a) {
      for (size_t b = 0; b < free_idx.size(); ++b)
        fit->covariance(free_idx[a], free_idx[b]) = obs.covariance(a, b) * scale;
      if (!obs.determined[a]) reasons[free_idx[a]] = obs.reasons[a];
    }
  }
  if (options.fix_aspect_ratio) {  // fy = fx
    fit->covariance.row(1) = fit->covariance.row(0);
    fit->covariance.col(1) = fit->covariance.col(0);
    reasons[1] = reasons[0];
  }
  for (int i = 0; i < np; ++i) {
    const std::string& name = fit->param_names[i];
    const std::string fixed_reason = internal::FixedReason(name, options);
    if (!fixed_reason.empty() && !(name == "fy" && options.fix_aspect_ratio)) reasons[i] = fixed_reason;
    const double s = std::sqrt(fit->covariance(i, i));
    if (reasons[i].empty()) reasons[i] = internal::SigmaTooLarge(name, s, options);
    if (!reasons[i].empty()) {
      fit->undetermined.push_back(name + ": " + reasons[i]);
      fit->covariance.row(i).setZero();
      fit->covariance.col(i).setZero();
      continue;
    }
    fit->sigmas[i] = s;
    fit->determined[i] = true;
  }
}

}  // namespace

IntrinsicsFit FitIntrinsics(const std::vector<calib::View>& views_in,
                            int width,
                            int height,
                            const IntrinsicsFitOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  IntrinsicsFit fit;
  fit.camera.model = options.model;
  fit.camera.width = width;
  fit.camera.height = height;
  fit.param_names = IntrinsicParamNames(options.model);
  fit.summary.problem = "intrinsics";
  std::string why;
  if (!options.Check(&why)) {
    fit.message = why;
    return fit;
  }
  if (width <= 0 || height <= 0) {
    fit.message = "image size " + std::to_string(width) + "x" + std::to_string(height) + " is not valid";
    return fit;
  }

  // 1. Build and initialise.
  const std::vector<calib::View> views = SelectViews(views_in, options, &fit);
  if (views.empty()) {
    fit.message = "fx, fy, cx, cy and the distortion cannot be determined: no view with at least " +
                  std::to_string(options.min_corners_per_view) + " corners (" + std::to_string(views_in.size()) +
                  " views given)";
    for (const auto& n : fit.param_names) fit.undetermined.push_back(n + ": no usable views");
    return fit;
  }
  std::optional<IntrinsicsStart> st = Initialise(views, options, &fit);
  if (!st) return fit;

  // 2. Solve: unit whitening (robust loss if asked), outlier rejection, final solve whitened by
  // the corner sigma.
  std::vector<std::vector<bool>> inlier(st->used.size());
  for (size_t v = 0; v < st->used.size(); ++v) inlier[v].assign(st->used[v].pixels.size(), true);
  const bool robust = options.loss != RobustLoss::kNone;
  ceres::Solver::Summary s1, s2;
  Solve(options, 1.0, robust, inlier, false, fit.param_names, &*st, &s1);
  const double sigma_used =
      RejectOutliers(Residuals(fit.camera, *st, options.fix_aspect_ratio), *st, options, &inlier, &fit);
  // 3. Observability (in the final solve).
  Observability obs =
      Solve(options, sigma_used, robust, inlier, options.compute_covariance, fit.param_names, &*st, &s2);
  if (!options.compute_covariance) obs.message = "not computed (compute_covariance off)";
  fit.summary = internal::ToSolveSummary("intrinsics", &s2);
  if (options.fix_aspect_ratio) st->params[1] = st->params[0];
  fit.camera.params = st->params;

  // 4. Outputs.
  int n = 0;
  const double sum_sq = MeasureRms(Residuals(fit.camera, *st, options.fix_aspect_ratio), inlier, *st, &n, &fit);
  fit.summary.rms_px = fit.rms_px;
  fit.summary.num_outliers = int(fit.rejected.size());
  const int num_free =
      int(fit.param_names.size()) - int(internal::FixedIntrinsicIndices(options).size()) + 6 * int(st->used.size());
  const int dof = 2 * n - num_free;
  const double sigma_hat = options.corner_sigma_px > 0 ? sigma_used : (dof > 0 ? std::sqrt(sum_sq / dof) : kNaN);
  fit.corner_sigma_px = sigma_hat;
  ReportCovariance(obs, (sigma_hat / sigma_used) * (sigma_hat / sigma_used), dof, options, &fit);
  fit.ok = true;
  const bool core_ok = fit.determined[0] && fit.determined[1] && fit.determined[2] && fit.determined[3];
  fit.summary.usable = fit.summary.usable && core_ok;
  std::ostringstream msg;
  msg << st->used.size() << " views (" << st->num_orientations << " orientations), " << n << " corners, RMS "
      << Fmt(fit.rms_px) << " px, corner sigma " << Fmt(sigma_hat) << " px";
  if (!fit.rejected.empty()) msg << ", " << fit.rejected.size() << " outliers rejected";
  if (!core_ok) msg << "; focal length / principal point NOT determined";
  if (st->num_orientations < 3)
    msg << "; WARNING: only " << st->num_orientations << " board orientations (use 10 or more)";
  fit.message = msg.str();
  fit.summary.message = fit.message + " | " + fit.summary.message;
  fit.summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return fit;
}

}  // namespace owlcal::fitting
