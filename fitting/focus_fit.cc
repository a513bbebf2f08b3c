#include "fitting/focus_fit.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace owlcal::fitting {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

struct Data {
  std::vector<double> x, y, w;  // dioptres, sigma [px], weight 1/se^2
};

double Model(const Eigen::Vector3d& p, double x) {
  return std::sqrt(p[0] * p[0] + p[1] * p[1] * (x - p[2]) * (x - p[2]));
}

double Chi2(const Data& d, const Eigen::Vector3d& p) {
  double c = 0;
  for (size_t i = 0; i < d.x.size(); ++i) {
    const double r = Model(p, d.x[i]) - d.y[i];
    c += d.w[i] * r * r;
  }
  return c;
}

// J^T W J and J^T W r at p (analytic derivatives of the model).
void Normal(const Data& d, const Eigen::Vector3d& p, Eigen::Matrix3d* jtj, Eigen::Vector3d* jtr) {
  jtj->setZero();
  jtr->setZero();
  for (size_t i = 0; i < d.x.size(); ++i) {
    const double m = std::max(1e-9, Model(p, d.x[i]));
    const double u = d.x[i] - p[2];
    const Eigen::Vector3d j(p[0] / m, p[1] * u * u / m, -p[1] * p[1] * u / m);
    *jtj += d.w[i] * j * j.transpose();
    *jtr += d.w[i] * j * (m - d.y[i]);
  }
}

}  // namespace

bool FocusFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "FocusFitOptions." + m;
    return false;
  };
  if (!(dof_blur_ratio > 1 && dof_blur_ratio < 10)) return fail("dof_blur_ratio must be in (1, 10)");
  if (!(min_se_px > 0)) return fail("min_se_px must be > 0");
  return true;
}

double FocusFit::Predict(double distance_m) const {
  return Model(Eigen::Vector3d(s0_px, k_px_per_dioptre, focus_dioptre), 1.0 / distance_m);
}

void DepthOfField(double s0, double k, double xf, double ratio, double* near_m, double* far_m) {
  if (!(k > 0)) {
    *near_m = 0;
    *far_m = kInf;
    return;
  }
  const double h = std::abs(s0) * std::sqrt(ratio * ratio - 1) / k;
  *near_m = 1.0 / (xf + h);
  *far_m = xf - h > 0 ? 1.0 / (xf - h) : kInf;
  if (xf + h <= 0) *near_m = kInf;  // in focus nowhere in front of the camera
}

FocusFit FitFocus(const std::vector<FocusSample>& samples, const FocusFitOptions& o) {
  FocusFit f;
  f.dof_blur_ratio = o.dof_blur_ratio;
  std::string why;
  if (!o.Check(&why)) {
    f.reason = why;
    return f;
  }
  Data d;
  f.min_distance_m = kInf;
  for (const FocusSample& s : samples) {
    if (!(s.distance_m > 0 && std::isfinite(s.distance_m) && s.sigma_px > 0 && std::isfinite(s.sigma_px))) continue;
    const double se = std::max(o.min_se_px, std::isfinite(s.se_px) ? s.se_px : 0.0);
    d.x.push_back(1.0 / s.distance_m);
    d.y.push_back(s.sigma_px);
    d.w.push_back(1.0 / (se * se));
    f.min_distance_m = std::min(f.min_distance_m, s.distance_m);
    f.max_distance_m = std::max(f.max_distance_m, s.distance_m);
  }
  f.num_samples = int(d.x.size());
  std::vector<double> distinct = d.x;
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  if (distinct.size() < 4) {
    f.reason = "too few distances: " + std::to_string(distinct.size()) + " (need 4 to fit blur, defocus and focus)";
    return f;
  }
  // Global start: for each x_f on a grid, sigma^2 = a + b (x - x_f)^2 is linear in (a, b)
  // (weights on sigma^2: 1 / (2 sigma se)^2).
  const double x_lo = distinct.front(), x_hi = distinct.back();
  Eigen::Vector3d best(0, 0, 0);
  double best_chi2 = kInf;
  const double span = x_hi - x_lo;
  for (double xf = x_lo - span; xf <= x_hi + span; xf += span / 200) {
    Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (size_t i = 0; i < d.x.size(); ++i) {
      const double w2 = d.w[i] / (4 * d.y[i] * d.y[i]);
      const Eigen::Vector2d row(1.0, (d.x[i] - xf) * (d.x[i] - xf));
      a += w2 * row * row.transpose();
      b += w2 * row * d.y[i] * d.y[i];
    }
    Eigen::Vector2d ab = a.ldlt().solve(b);
    ab = ab.cwiseMax(Eigen::Vector2d(1e-6, 0.0));
    const Eigen::Vector3d p(std::sqrt(ab[0]), std::sqrt(ab[1]), xf);
    const double c = Chi2(d, p);
    if (c < best_chi2) best_chi2 = c, best = p;
  }
  // Gauss-Newton (Levenberg damping) on (s0, k, x_f).
  Eigen::Vector3d p = best;
  double chi2 = best_chi2, lambda = 1e-3;
  for (int it = 0; it < 100; ++it) {
    Eigen::Matrix3d jtj;
    Eigen::Vector3d jtr;
    Normal(d, p, &jtj, &jtr);
    Eigen::Matrix3d a = jtj;
    a.diagonal() *= 1 + lambda;
    a.diagonal().array() += 1e-12;
    const Eigen::Vector3d step = a.ldlt().solve(-jtr);
    Eigen::Vector3d q = p + step;
    q[0] = std::abs(q[0]);
    q[1] = std::abs(q[1]);
    const double c = Chi2(d, q);
    if (c < chi2) {
      const bool done = chi2 - c < 1e-12 * (1 + chi2);
      p = q;
      chi2 = c;
      lambda = std::max(1e-9, lambda / 10);
      if (done) break;
    } else {
      lambda *= 10;
      if (lambda > 1e9) break;
    }
  }
  Eigen::Matrix3d jtj;
  Eigen::Vector3d jtr;
  Normal(d, p, &jtj, &jtr);
  const int dof = f.num_samples - 3;
  f.chi2_per_dof = dof > 0 ? chi2 / dof : 0;
  Eigen::Matrix3d cov = jtj.completeOrthogonalDecomposition().pseudoInverse();
  if (f.chi2_per_dof > 1) cov *= f.chi2_per_dof;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) f.cov[r][c] = cov(r, c);
  f.s0_px = p[0];
  f.k_px_per_dioptre = p[1];
  f.focus_dioptre = p[2];
  f.s0_sigma_px = std::sqrt(std::max(0.0, cov(0, 0)));
  f.k_sigma = std::sqrt(std::max(0.0, cov(1, 1)));
  f.focus_dioptre_sigma = std::sqrt(std::max(0.0, cov(2, 2)));
  f.focus_found = f.k_px_per_dioptre > 2 * f.k_sigma && std::isfinite(f.focus_dioptre_sigma);
  if (f.focus_found) {
    f.focus_m = f.focus_dioptre > 0 ? 1.0 / f.focus_dioptre : kInf;
    f.focus_sigma_m = f.focus_dioptre > 0 ? f.focus_dioptre_sigma / (f.focus_dioptre * f.focus_dioptre) : kInf;
    DepthOfField(p[0], p[1], p[2], o.dof_blur_ratio, &f.dof_near_m, &f.dof_far_m);
    // Delta method with central differences (the limits are smooth where finite).
    Eigen::Vector3d g_near, g_far;
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(p[k]));
      Eigen::Vector3d a = p, b = p;
      a[k] += h;
      b[k] -= h;
      double na, fa, nb, fb;
      DepthOfField(a[0], a[1], a[2], o.dof_blur_ratio, &na, &fa);
      DepthOfField(b[0], b[1], b[2], o.dof_blur_ratio, &nb, &fb);
      g_near[k] = (na - nb) / (2 * h);
      g_far[k] = std::isfinite(fa) && std::isfinite(fb) ? (fa - fb) / (2 * h) : 0;
    }
    f.dof_near_sigma_m = std::sqrt(std::max(0.0, double(g_near.transpose() * cov * g_near)));
    f.dof_far_sigma_m =
        std::isfinite(f.dof_far_m) ? std::sqrt(std::max(0.0, double(g_far.transpose() * cov * g_far))) : 0;
  } else {
    // No defocus shows: everything measured is in focus; the limits are the measured range.
    f.focus_m = kInf;
    f.dof_near_m = f.min_distance_m;
    f.dof_far_m = f.max_distance_m;
  }
  f.ok = std::isfinite(chi2) && f.s0_px > 0;
  if (!f.ok) f.reason = "the fit did not converge";
  return f;
}

}  // namespace owlcal::fitting
