#include "fitting/projection_uncertainty.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "fitting/intrinsics_fit.h"

namespace owlcal::fitting {
namespace {

// Pixel of a ray (x, y, 1) for parameters p.
bool ProjectRay(const models::CameraIntrinsics& c,
                const std::vector<double>& p,
                const Eigen::Vector3d& ray,
                Eigen::Vector2d* q) {
  models::CameraIntrinsics t = c;
  t.params = p;
  double pix[2];
  if (!t.Project(ray.data(), pix)) return false;
  *q = Eigen::Vector2d(pix[0], pix[1]);
  return true;
}

}  // namespace

UncertaintyGrid ProjectionUncertainty(const models::CameraIntrinsics& c, const Eigen::MatrixXd& cov, int nx) {
  UncertaintyGrid g;
  g.nx = std::max(2, nx);
  g.ny = std::max(2, int(std::lround(double(c.height) / c.width * g.nx)));
  const int n = int(c.params.size()), cells = g.nx * g.ny;
  g.x_px.resize(cells);
  g.y_px.resize(cells);
  g.sigma_px.assign(cells, NAN);
  std::vector<Eigen::Vector3d> rays(cells);
  std::vector<bool> ok(cells, false);
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      const int k = j * g.nx + i;
      g.x_px[k] = (c.width - 1) * i / double(g.nx - 1);
      g.y_px[k] = (c.height - 1) * j / double(g.ny - 1);
      double pix[2] = {g.x_px[k], g.y_px[k]}, r[3];
      ok[k] = c.Unproject(pix, r);
      rays[k] = Eigen::Vector3d(r[0], r[1], 1.0);
    }
  if (cov.rows() != n || cov.cols() != n) return g;
  // Jacobians d pixel / d params (central differences) and d pixel / d rotation of the ray.
  Eigen::MatrixXd Jp = Eigen::MatrixXd::Zero(2 * cells, n), Jr = Eigen::MatrixXd::Zero(2 * cells, 3);
  for (int k = 0; k < cells; ++k) {
    if (!ok[k]) continue;
    for (int a = 0; a < n; ++a) {
      const double h = a < 4 ? 1e-4 : 1e-7;
      std::vector<double> pp = c.params, pm = c.params;
      pp[a] += h;
      pm[a] -= h;
      Eigen::Vector2d qp, qm;
      if (!ProjectRay(c, pp, rays[k], &qp) || !ProjectRay(c, pm, rays[k], &qm)) {
        ok[k] = false;
        break;
      }
      Jp.block(2 * k, a, 2, 1) = (qp - qm) / (2 * h);
    }
    for (int a = 0; a < 3 && ok[k]; ++a) {
      const double h = 1e-7;
      Eigen::Vector3d w = Eigen::Vector3d::Zero();
      w[a] = h;
      const Eigen::Vector3d rp = rays[k] + w.cross(rays[k]), rm = rays[k] - w.cross(rays[k]);
      Eigen::Vector2d qp, qm;
      if (!ProjectRay(c, c.params, rp, &qp) || !ProjectRay(c, c.params, rm, &qm)) {
        ok[k] = false;
        break;
      }
      Jr.block(2 * k, a, 2, 1) = (qp - qm) / (2 * h);
    }
    if (!ok[k]) {
      Jp.middleRows(2 * k, 2).setZero();
      Jr.middleRows(2 * k, 2).setZero();
    }
  }
  // Remove what a common rotation explains: J <- J - Jr (Jr^+ J), least squares over the grid.
  const Eigen::MatrixXd rot = Jr.colPivHouseholderQr().solve(Jp);
  const Eigen::MatrixXd J = Jp - Jr * rot;
  for (int k = 0; k < cells; ++k) {
    if (!ok[k]) continue;
    const Eigen::Matrix2d S = J.middleRows(2 * k, 2) * cov * J.middleRows(2 * k, 2).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(S);
    g.sigma_px[k] = std::sqrt(std::max(0.0, es.eigenvalues()(1)));
  }
  return g;
}

Eigen::MatrixXd IntrinsicsCovariance(const CalibrationResult& r, int eye, std::string* source) {
  const models::CameraIntrinsics* cam =
      r.cameras[eye] ? &*r.cameras[eye] : (r.head ? &r.head->intrinsics[eye] : nullptr);
  if (!cam) return {};
  const std::string prefix = eye == 0 ? "left." : "right.";
  const std::vector<std::string> names = IntrinsicParamNames(cam->model);
  const int n = int(names.size());
  Eigen::MatrixXd C = Eigen::MatrixXd::Zero(n, n);
  if (r.stereo && r.stereo->full_covariance.rows() == int(r.stereo->full_names.size())) {
    std::vector<int> idx(n, -1);
    for (int i = 0; i < n; ++i)
      for (size_t k = 0; k < r.stereo->full_names.size(); ++k)
        if (r.stereo->full_names[k] == prefix + names[i]) idx[i] = int(k);
    if (std::all_of(idx.begin(), idx.end(), [](int i) { return i >= 0; })) {
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          const double v = r.stereo->full_covariance(idx[i], idx[j]);
          C(i, j) = std::isfinite(v) ? v : 0.0;
        }
      if (source) *source = "stereo fit joint covariance";
      return C;
    }
  }
  for (int i = 0; i < n; ++i) {
    const Parameter* p = r.Find(prefix + names[i]);
    if (p && p->determined && std::isfinite(p->sigma)) C(i, i) = p->sigma * p->sigma;
  }
  if (source) *source = "the parameters' \u03c3, no correlations: an upper bound";
  return C;
}

ValidIntrinsicsRegion ComputeValidIntrinsicsRegion(const models::CameraIntrinsics& c,
                                                   const Eigen::MatrixXd& cov,
                                                   const std::vector<CornerResidual>& residuals,
                                                   double observed_sigma_px,
                                                   const ValidRegionOptions& o) {
  ValidIntrinsicsRegion v;
  v.observed_sigma_px = observed_sigma_px;
  v.uncertainty = ProjectionUncertainty(c, cov, o.gridn_width);
  const UncertaintyGrid& g = v.uncertainty;
  const int cells = g.nx * g.ny;
  v.mean_px.assign(cells, 0);
  v.stdev_px.assign(cells, 0);
  v.count.assign(cells, 0);
  v.valid.assign(cells, false);
  // Residual statistics per cell: cell centres at the grid points, half a cell either way.
  const double hw = (c.width - 1) / double(g.nx - 1) / 2, hh = (c.height - 1) / double(g.ny - 1) / 2;
  std::vector<std::vector<double>> vals(cells);
  for (const auto& r : residuals) {
    const int i = int(std::lround(r.x / (2 * hw))), j = int(std::lround(r.y / (2 * hh)));
    if (i < 0 || i >= g.nx || j < 0 || j >= g.ny) continue;
    const int k = j * g.nx + i;
    if (std::abs(r.x - g.x_px[k]) >= hw || std::abs(r.y - g.y_px[k]) >= hh) continue;
    vals[k].push_back(r.dx);
    vals[k].push_back(r.dy);
  }
  cv::Mat mask = cv::Mat::zeros(g.ny, g.nx, CV_8U);
  int num_valid = 0;
  for (int k = 0; k < cells; ++k) {
    const auto& e = vals[k];
    v.count[k] = int(e.size());
    if (e.size() > 5) {
      double m = 0, s = 0;
      for (double x : e) m += x;
      m /= e.size();
      for (double x : e) s += (x - m) * (x - m);
      v.mean_px[k] = m;
      v.stdev_px[k] = std::sqrt(s / e.size());
    }
    const double u = g.sigma_px[k];
    v.valid[k] = std::isfinite(u) && u < o.threshold_uncertainty * observed_sigma_px &&
                 std::abs(v.mean_px[k]) < o.threshold_mean_px &&
                 v.stdev_px[k] < o.threshold_stdev * observed_sigma_px && v.count[k] > o.threshold_count;
    if (v.valid[k]) {
      mask.at<uint8_t>(k / g.nx, k % g.nx) = 1;
      ++num_valid;
    }
  }
  v.valid_fraction = cells ? double(num_valid) / cells : 0.0;
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  double best = -1;
  const std::vector<cv::Point>* pick = nullptr;
  for (const auto& ct : contours) {
    const double a = cv::contourArea(ct);
    if (a > best) {
      best = a;
      pick = &ct;
    }
  }
  // A closed outline needs at least 3 distinct points (4 with the repeat).
  if (pick && pick->size() >= 3) {
    for (const cv::Point& p : *pick)
      v.contour.emplace_back(std::round(p.x * (c.width - 1) / double(g.nx - 1)),
                             std::round(p.y * (c.height - 1) / double(g.ny - 1)));
    v.contour.push_back(v.contour.front());
  }
  return v;
}

}  // namespace owlcal::fitting
