#include "evaluation/projection_diff.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Dense>
#include <Eigen/Geometry>

namespace owlcal::evaluation {
namespace {

Eigen::Matrix3d Exp(const Eigen::Vector3d& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Eigen::Matrix3d::Identity();
}

}  // namespace

ProjectionDiff CompareProjection(const models::CameraIntrinsics& a,
                                 const models::CameraIntrinsics& b,
                                 int cols,
                                 int rows,
                                 double fit_radius_fraction) {
  ProjectionDiff out;
  out.grid_cols = cols;
  out.grid_rows = rows;
  if (a.width != b.width || a.height != b.height || cols < 2 || rows < 2) {
    out.message = "calibrations of different image sizes, or a grid under 2x2";
    return out;
  }
  const double W = a.width, H = a.height;
  const Eigen::Vector2d centre((W - 1) / 2, (H - 1) / 2);
  const double radius = fit_radius_fraction * centre.norm();
  // Pixels a's lens model cannot unproject (a wild distortion fit folds back on itself) get
  // an infinite difference and stay out of the rotation fit.
  std::vector<Eigen::Vector3d> rays;
  std::vector<bool> valid, in_fit;
  int invalid = 0;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const Eigen::Vector2d q((c + 0.5) * W / cols - 0.5, (r + 0.5) * H / rows - 0.5);
      Eigen::Vector3d ray = Eigen::Vector3d::UnitZ();
      const bool ok = a.Unproject(q.data(), ray.data()) && ray.allFinite();
      invalid += !ok;
      out.pixels.push_back(q);
      rays.push_back(ray.normalized());
      valid.push_back(ok);
      in_fit.push_back(ok && (q - centre).norm() <= radius);
    }
  }
  if (invalid * 4 > rows * cols) {
    out.message = std::to_string(invalid) + " of " + std::to_string(rows * cols) +
                  " grid pixels cannot be unprojected through the first calibration";
    return out;
  }
  // Residuals of the fit pixels (fit_only) or of every pixel (NaN where not valid).
  auto residuals = [&](const Eigen::Matrix3d& R, bool fit_only, Eigen::VectorXd* res) {
    std::vector<double> v;
    for (size_t i = 0; i < rays.size(); ++i) {
      if (fit_only && !in_fit[i]) continue;
      const Eigen::Vector3d x = R * rays[i];
      Eigen::Vector2d q;
      if (!valid[i] || !b.Project(x.data(), q.data())) {
        if (fit_only) return false;
        q = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
      }
      v.push_back(q.x() - out.pixels[i].x());
      v.push_back(q.y() - out.pixels[i].y());
    }
    *res = Eigen::Map<Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
    return true;
  };
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  for (int it = 0; it < 20; ++it) {
    Eigen::VectorXd r0;
    if (!residuals(R, true, &r0)) break;
    Eigen::MatrixXd J(r0.size(), 3);
    for (int k = 0; k < 3; ++k) {
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      w[k] = 1e-7;
      Eigen::VectorXd rp, rm;
      if (!residuals(Exp(w) * R, true, &rp) || !residuals(Exp(-w) * R, true, &rm)) break;
      J.col(k) = (rp - rm) / 2e-7;
    }
    const Eigen::Vector3d step = (J.transpose() * J).ldlt().solve(-J.transpose() * r0);
    if (!step.allFinite()) break;
    R = Exp(step) * R;
    if (step.norm() < 1e-12) break;
  }
  out.rotation_deg = Eigen::AngleAxisd(R).angle() * 180 / M_PI;
  Eigen::VectorXd res;
  if (!residuals(R, false, &res)) {
    out.message = "a rotated ray falls outside the second calibration's field";
    return out;
  }
  for (size_t i = 0; i < rays.size(); ++i) {
    const double d = std::hypot(res[2 * i], res[2 * i + 1]);
    out.diff_px.push_back(std::isfinite(d) ? d : std::numeric_limits<double>::infinity());
  }
  std::vector<double> s = out.diff_px;
  std::sort(s.begin(), s.end());
  out.median_px = s[s.size() / 2];
  out.p90_px = s[std::min(s.size() - 1, static_cast<size_t>(0.9 * s.size()))];
  out.max_px = s.back();
  Eigen::Vector3d ray_c;
  Eigen::Vector2d qc;
  if (a.Unproject(centre.data(), ray_c.data())) {
    const Eigen::Vector3d x = R * ray_c;
    if (b.Project(x.data(), qc.data())) out.centre_px = (qc - centre).norm();
  }
  out.ok = true;
  return out;
}

}  // namespace owlcal::evaluation
