#include "fitting/radtan_refit.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>

namespace owlcal::fitting {

RadtanRefit FitRadtan4(const models::CameraIntrinsics& c, int grid) {
  RadtanRefit out;
  out.camera = c;
  out.camera.model = models::DistortionModel::kOpenCv5;
  out.camera.params.assign(c.params.begin(), c.params.begin() + 4);
  for (int i = 0; i < 4; ++i) out.camera.params.push_back(c.params[4 + i]);
  out.camera.params.push_back(0.0);
  out.exact = true;
  for (size_t i = 8; i < c.params.size(); ++i) out.exact = out.exact && c.params[i] == 0.0;

  // Rays of a grid over the image, corners and edges included.
  const int nx = std::max(2, grid), ny = std::max(2, int(std::lround(grid * double(c.height) / c.width)));
  std::vector<Eigen::Vector2d> pix, ray;
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      const double p[2] = {(c.width - 1) * i / double(nx - 1), (c.height - 1) * j / double(ny - 1)};
      double r[3];
      if (!c.Unproject(p, r)) continue;
      pix.emplace_back(p[0], p[1]);
      ray.emplace_back(r[0], r[1]);
    }
  const int total = nx * ny;
  if (int(pix.size()) < total / 2) {
    out.message = "the lens model cannot be inverted over " + std::to_string(total - int(pix.size())) + " of " +
                  std::to_string(total) + " image points";
    return out;
  }
  const double fx = c.params[0], fy = c.params[1], cx = c.params[2], cy = c.params[3];
  if (!out.exact) {
    // u = fx (x (1 + k1 r2 + k2 r4) + 2 p1 x y + p2 (r2 + 2 x^2)) + cx, and likewise v: linear in
    // (k1, k2, p1, p2).
    Eigen::MatrixXd A(2 * pix.size(), 4);
    Eigen::VectorXd b(2 * pix.size());
    for (size_t k = 0; k < pix.size(); ++k) {
      const double x = ray[k].x(), y = ray[k].y(), r2 = x * x + y * y;
      A.row(2 * k) << fx * x * r2, fx * x * r2 * r2, fx * 2 * x * y, fx * (r2 + 2 * x * x);
      A.row(2 * k + 1) << fy * y * r2, fy * y * r2 * r2, fy * (r2 + 2 * y * y), fy * 2 * x * y;
      b(2 * k) = pix[k].x() - cx - fx * x;
      b(2 * k + 1) = pix[k].y() - cy - fy * y;
    }
    const Eigen::Vector4d d = A.colPivHouseholderQr().solve(b);
    for (int i = 0; i < 4; ++i) out.camera.params[4 + i] = d[i];
  }
  double sum2 = 0;
  for (size_t k = 0; k < pix.size(); ++k) {
    const double p3[3] = {ray[k].x(), ray[k].y(), 1.0};
    double q[2];
    out.camera.Project(p3, q);
    const double e = std::hypot(q[0] - pix[k].x(), q[1] - pix[k].y());
    out.max_error_px = std::max(out.max_error_px, e);
    sum2 += e * e;
  }
  out.num_points = int(pix.size());
  out.rms_error_px = std::sqrt(sum2 / pix.size());
  out.ok = true;
  return out;
}

}  // namespace owlcal::fitting
