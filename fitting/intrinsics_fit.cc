#include "fitting/intrinsics_fit.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <set>
#include <sstream>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "fitting/covariance_marginal.h"
#include "fitting/intrinsics_residual.h"

namespace owlcal::fitting {
namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string Fmt(double v, int prec = 4) {
  std::ostringstream s;
  s.precision(prec);
  s << v;
  return s.str();
}

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
  if (o.fix_k3) fixed.push_back(8);
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
  if ((name == "cx" || name == "cy") && o.fix_principal_point) return "fixed at the image centre by option fix_principal_point";
  if ((name == "p1" || name == "p2") && o.fix_tangential) return "fixed at 0 by option fix_tangential";
  if (name == "k3" && o.fix_k3) return "fixed at 0 by option fix_k3";
  return "";
}

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
  if (min_corners_per_view < 4) return fail("min_corners_per_view must be >= 4, got " + std::to_string(min_corners_per_view));
  if (max_iterations < 1) return fail("max_iterations must be >= 1, got " + std::to_string(max_iterations));
  if (!(max_sigma_px > 0)) return fail("max_sigma_px must be > 0, got " + Fmt(max_sigma_px));
  if (!(max_sigma_distortion > 0)) return fail("max_sigma_distortion must be > 0, got " + Fmt(max_sigma_distortion));
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
  const int np = 4 + fit.camera.NumDistortion();
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
  const std::string all_params = "fx, fy, cx, cy and the distortion";

  // 1. Views with enough corners.
  std::vector<calib::View> views;
  for (const calib::View& v : views_in) {
    if (int(v.pixels.size()) < options.min_corners_per_view) {
      fit.dropped_views.push_back("frame " + std::to_string(v.frame_index) + ": " + std::to_string(v.pixels.size()) +
                                  " corners < min_corners_per_view " + std::to_string(options.min_corners_per_view));
      continue;
    }
    views.push_back(v);
  }
  if (views.empty()) {
    fit.message = all_params + " cannot be determined: no view with at least " +
                  std::to_string(options.min_corners_per_view) + " corners (" + std::to_string(views_in.size()) +
                  " views given)";
    for (const auto& n : fit.param_names) fit.undetermined.push_back(n + ": no usable views");
    return fit;
  }

  // 2. Initialisation: Zhang (cv::initCameraMatrix2D, principal point at the centre), then
  // one solvePnP per view with no distortion.
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const calib::View& v : views) {
    std::vector<cv::Point3f> op;
    std::vector<cv::Point2f> ip;
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      op.emplace_back(float(v.points_in_target[i].x()), float(v.points_in_target[i].y()), float(v.points_in_target[i].z()));
      ip.emplace_back(float(v.pixels[i].x()), float(v.pixels[i].y()));
    }
    object_points.push_back(op);
    image_points.push_back(ip);
  }
  cv::Mat K;
  try {
    K = cv::initCameraMatrix2D(object_points, image_points, cv::Size(width, height), options.fix_aspect_ratio ? 1.0 : 0.0);
  } catch (const cv::Exception& e) {
    fit.message = all_params + " cannot be determined: initialisation failed (" + e.what() + ")";
    return fit;
  }
  double fx0 = K.at<double>(0, 0), fy0 = K.at<double>(1, 1);
  if (!(fx0 > 0 && fy0 > 0 && std::isfinite(fx0) && std::isfinite(fy0))) {
    fx0 = fy0 = 0.8 * std::max(width, height);  // homographies degenerate; a generic guess
  }
  std::vector<double> params(np, 0.0);
  params[0] = fx0;
  params[1] = options.fix_aspect_ratio ? fx0 : fy0;
  params[2] = (width - 1) / 2.0;
  params[3] = (height - 1) / 2.0;
  cv::Mat K0 = (cv::Mat_<double>(3, 3) << params[0], 0, params[2], 0, params[1], params[3], 0, 0, 1);
  std::vector<std::array<double, 7>> poses;
  std::vector<calib::View> used;
  std::vector<models::Rigid3d> init_poses;
  for (size_t i = 0; i < views.size(); ++i) {
    cv::Mat rvec, tvec;
    bool ok = false;
    try {
      ok = cv::solvePnP(object_points[i], image_points[i], K0, cv::noArray(), rvec, tvec);
    } catch (const cv::Exception&) {
      ok = false;
    }
    if (!ok || tvec.at<double>(2) <= 0) {
      fit.dropped_views.push_back("frame " + std::to_string(views[i].frame_index) + ": initial pose not found");
      continue;
    }
    const models::Rigid3d pose = PoseFromRvecTvec(rvec, tvec);
    std::array<double, 7> a;
    pose.ToArray(a.data());
    poses.push_back(a);
    init_poses.push_back(pose);
    used.push_back(views[i]);
  }
  // Board orientations that differ by more than 3 degrees.
  std::vector<models::Rigid3d> distinct;
  for (const auto& p : init_poses) {
    bool is_new = true;
    for (const auto& q : distinct)
      if (AngleBetween(p, q) < 3.0 * M_PI / 180) is_new = false;
    if (is_new) distinct.push_back(p);
  }
  if (used.empty() || distinct.size() < 2) {
    fit.message = all_params + " cannot be determined: " +
                  (used.empty() ? std::string("no view could be initialised")
                                : std::to_string(used.size()) + " view(s) but all show the board in ONE orientation "
                                                                "(one pose only, or the board never moved); tilt the "
                                                                "board (or move the camera) between views");
    for (const auto& n : fit.param_names) fit.undetermined.push_back(n + ": board seen in one orientation only");
    return fit;
  }

  const std::vector<int> fixed = internal::FixedIntrinsicIndices(options);
  auto solve = [&](double sigma, bool robust, const std::vector<std::vector<bool>>& inlier,
                   ceres::Solver::Summary* summary, bool want_covariance) {
    ceres::Problem::Options po;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    PoseManifold pose_manifold;
    std::unique_ptr<ceres::SubsetManifold> subset;
    problem.AddParameterBlock(params.data(), np);
    if (!fixed.empty()) {
      subset = std::make_unique<ceres::SubsetManifold>(np, fixed);
      problem.SetManifold(params.data(), subset.get());
    }
    for (size_t v = 0; v < used.size(); ++v) {
      problem.AddParameterBlock(poses[v].data(), 7, &pose_manifold);
      for (size_t i = 0; i < used[v].pixels.size(); ++i) {
        if (!inlier[v][i]) continue;
        ceres::CostFunction* cost = models::VisitCameraModel(options.model, [&]<typename Cam>() {
          return internal::CornerResidual<Cam>::Create(used[v].pixels[i], used[v].points_in_target[i], 1.0 / sigma,
                                                       options.fix_aspect_ratio);
        });
        ceres::LossFunction* loss = nullptr;
        if (robust) {
          if (options.loss == RobustLoss::kCauchy) {
            loss = new ceres::CauchyLoss(options.loss_scale_sigma);
          } else {
            loss = new ceres::HuberLoss(options.loss_scale_sigma);
          }
        }
        problem.AddResidualBlock(cost, loss, params.data(), poses[v].data());
      }
    }
    ceres::Solver::Options so;
    so.linear_solver_type = ceres::DENSE_SCHUR;
    so.max_num_iterations = options.max_iterations;
    so.function_tolerance = 1e-12;
    so.parameter_tolerance = 1e-12;
    so.gradient_tolerance = 1e-12;
    so.num_threads = 1;
    ceres::Solve(so, &problem, summary);
    MarginalCovariance mc;
    if (want_covariance) {
      std::vector<double*> locals;
      for (auto& p : poses) locals.push_back(p.data());
      mc = ComputeMarginalCovariance(&problem, {params.data()}, locals);
    }
    return mc;
  };

  // Residual (pixel error) of every corner at the current estimate.
  auto residuals = [&]() {
    std::vector<std::vector<Eigen::Vector2d>> r(used.size());
    for (size_t v = 0; v < used.size(); ++v) {
      const models::Rigid3d pose = models::Rigid3d::Map(poses[v].data());
      models::CameraIntrinsics cam = fit.camera;
      cam.params = params;
      if (options.fix_aspect_ratio) cam.params[1] = cam.params[0];
      for (size_t i = 0; i < used[v].pixels.size(); ++i) {
        const Eigen::Vector3d p = pose * used[v].points_in_target[i];
        double px[2] = {kNaN, kNaN};
        cam.Project(p.data(), px);
        r[v].push_back(Eigen::Vector2d(px[0], px[1]) - used[v].pixels[i]);
      }
    }
    return r;
  };

  // 3. First solve: no/huber loss, unit whitening.
  std::vector<std::vector<bool>> inlier(used.size());
  for (size_t v = 0; v < used.size(); ++v) inlier[v].assign(used[v].pixels.size(), true);
  ceres::Solver::Summary s1;
  solve(1.0, options.loss != RobustLoss::kNone, inlier, &s1, false);
  // 4. Robust noise estimate and outlier rejection.
  auto r = residuals();
  std::vector<double> comps;
  for (const auto& rv : r)
    for (const auto& e : rv) {
      comps.push_back(std::abs(e.x()));
      comps.push_back(std::abs(e.y()));
    }
  std::nth_element(comps.begin(), comps.begin() + comps.size() / 2, comps.end());
  const double sigma_mad = std::max(1e-4, 1.4826 * comps[comps.size() / 2]);
  const double sigma_used = options.corner_sigma_px > 0 ? options.corner_sigma_px : sigma_mad;
  if (options.outlier_threshold_sigma > 0) {
    for (size_t v = 0; v < used.size(); ++v)
      for (size_t i = 0; i < r[v].size(); ++i) {
        const double e = r[v][i].norm();
        if (!std::isfinite(e) || e > options.outlier_threshold_sigma * sigma_used) {
          inlier[v][i] = false;
          fit.rejected.push_back({used[v].frame_index, used[v].eye, used[v].corner_ids[i], e});
        }
      }
  }
  // 5. Final solve, whitened by the corner sigma.
  ceres::Solver::Summary s2;
  MarginalCovariance mc = solve(sigma_used, options.loss != RobustLoss::kNone, inlier, &s2, true);
  fit.summary = internal::ToSolveSummary("intrinsics", &s2);
  if (options.fix_aspect_ratio) params[1] = params[0];
  fit.camera.params = params;

  // 6. RMS (OpenCV's definition: sqrt(sum |e|^2 / corners)) over inliers, per view and overall.
  r = residuals();
  double sum_sq = 0;
  int n = 0;
  for (size_t v = 0; v < used.size(); ++v) {
    double sv = 0;
    int nv = 0;
    for (size_t i = 0; i < r[v].size(); ++i) {
      if (!inlier[v][i]) continue;
      sv += r[v][i].squaredNorm();
      ++nv;
    }
    fit.view_rms_px.push_back(nv ? std::sqrt(sv / nv) : kNaN);
    fit.frame_indices.push_back(used[v].frame_index);
    fit.cam_from_target.push_back(models::Rigid3d::Map(poses[v].data()));
    sum_sq += sv;
    n += nv;
  }
  fit.rms_px = std::sqrt(sum_sq / std::max(1, n));
  fit.summary.rms_px = fit.rms_px;
  fit.summary.num_outliers = int(fit.rejected.size());
  const int num_free = np - int(fixed.size()) + 6 * int(used.size());
  const int dof = 2 * n - num_free;
  double sigma_hat = sigma_used;
  if (options.corner_sigma_px <= 0) {
    sigma_hat = dof > 0 ? std::sqrt(sum_sq / dof) : kNaN;
  }
  fit.corner_sigma_px = sigma_hat;

  // 7. Covariance in full parameter space; observability.
  fit.covariance = Eigen::MatrixXd::Zero(np, np);
  fit.sigmas.assign(np, kNaN);
  fit.determined.assign(np, false);
  std::vector<int> free_idx;
  for (int i = 0; i < np; ++i)
    if (std::find(fixed.begin(), fixed.end(), i) == fixed.end()) free_idx.push_back(i);
  const double scale = (sigma_hat / sigma_used) * (sigma_hat / sigma_used);
  std::vector<std::string> reasons(np);
  if (!mc.ok || dof <= 0 || !std::isfinite(scale)) {
    for (int i : free_idx)
      reasons[i] = dof <= 0 ? "more parameters than measurements" : "covariance failed: " + mc.message;
  } else {
    for (size_t a = 0; a < free_idx.size(); ++a) {
      for (size_t b = 0; b < free_idx.size(); ++b)
        fit.covariance(free_idx[a], free_idx[b]) = mc.covariance(a, b) * scale;
      if (!mc.determined[a]) reasons[free_idx[a]] = mc.reasons[a];
    }
  }
  if (options.fix_aspect_ratio) {  // fy = fx
    fit.covariance.row(1) = fit.covariance.row(0);
    fit.covariance.col(1) = fit.covariance.col(0);
    reasons[1] = reasons[0];
  }
  for (int i = 0; i < np; ++i) {
    const std::string& name = fit.param_names[i];
    const std::string fixed_reason = internal::FixedReason(name, options);
    if (!fixed_reason.empty() && !(name == "fy" && options.fix_aspect_ratio)) {
      fit.undetermined.push_back(name + ": " + fixed_reason);
      fit.sigmas[i] = kNaN;
      fit.covariance.row(i).setZero();
      fit.covariance.col(i).setZero();
      continue;
    }
    const double s = std::sqrt(fit.covariance(i, i));
    if (reasons[i].empty()) reasons[i] = internal::SigmaTooLarge(name, s, options);
    if (!reasons[i].empty()) {
      fit.undetermined.push_back(name + ": " + reasons[i]);
      fit.covariance.row(i).setZero();
      fit.covariance.col(i).setZero();
      continue;
    }
    fit.sigmas[i] = s;
    fit.determined[i] = true;
  }
  fit.ok = true;
  const bool core_ok = fit.determined[0] && fit.determined[1] && fit.determined[2] && fit.determined[3];
  fit.summary.usable = fit.summary.usable && core_ok;
  std::ostringstream msg;
  msg << used.size() << " views (" << distinct.size() << " orientations), " << n << " corners, RMS " << Fmt(fit.rms_px)
      << " px, corner sigma " << Fmt(sigma_hat) << " px";
  if (!fit.rejected.empty()) msg << ", " << fit.rejected.size() << " outliers rejected";
  if (!core_ok) msg << "; focal length / principal point NOT determined";
  if (distinct.size() < 3) msg << "; WARNING: only " << distinct.size() << " board orientations (use 10 or more)";
  fit.message = msg.str();
  fit.summary.message = fit.message + " | " + fit.summary.message;
  fit.summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return fit;
}

void AppendIntrinsicsToResult(const IntrinsicsFit& fit, const std::string& eye_name, CalibrationResult* result) {
  SolveSummary s = fit.summary;
  s.problem = "intrinsics." + eye_name;
  result->summaries.push_back(s);
  if (!fit.ok) {
    result->warnings.push_back(eye_name + " intrinsics: " + fit.message);
    for (const auto& u : fit.undetermined) {
      const std::string name = u.substr(0, u.find(':'));
      Parameter p{eye_name + "." + name, kNaN, kNaN, IntrinsicParamUnit(name), std::nullopt, false, u.substr(u.find(':') + 2)};
      result->Set(p);
    }
    return;
  }
  const int eye = eye_name == "right" ? 1 : 0;
  result->cameras[eye] = fit.camera;
  for (size_t i = 0; i < fit.param_names.size(); ++i) {
    Parameter p;
    p.name = eye_name + "." + fit.param_names[i];
    p.value = fit.camera.params[i];
    p.sigma = fit.sigmas[i];
    p.unit = IntrinsicParamUnit(fit.param_names[i]);
    p.determined = fit.determined[i];
    for (const auto& u : fit.undetermined)
      if (u.rfind(fit.param_names[i] + ":", 0) == 0) p.note = u.substr(fit.param_names[i].size() + 2);
    result->Set(p);
  }
  for (const auto& u : fit.undetermined) result->warnings.push_back(eye_name + "." + u);
  nlohmann::json d;
  d["rms_px"] = fit.rms_px;
  d["corner_sigma_px"] = fit.corner_sigma_px;
  d["frames"] = fit.frame_indices;
  d["view_rms_px"] = fit.view_rms_px;
  d["dropped_views"] = fit.dropped_views;
  nlohmann::json rej = nlohmann::json::array();
  for (const auto& r : fit.rejected)
    rej.push_back({{"frame", r.frame_index}, {"corner", r.corner_id}, {"residual_px", r.residual_px}});
  d["rejected"] = rej;
  result->diagnostics["intrinsics"][eye_name] = d;
}

}  // namespace owlcal::fitting
