#include "fitting/range_datum_fit.h"

#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Dense>

#include "fitting/format.h"

namespace owlcal::fitting {
namespace {

struct Line {
  bool ok = false;
  double a = 0, b = 1, chi2 = 0;
  Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
};

Line FitLine(const std::vector<DatumFitRow>& rows, int skip) {
  Line l;
  double b = 1;
  for (int it = 0; it < 5; ++it) {
    Eigen::Matrix2d N = Eigen::Matrix2d::Zero();
    Eigen::Vector2d r = Eigen::Vector2d::Zero();
    for (int i = 0; i < static_cast<int>(rows.size()); ++i) {
      if (i == skip) continue;
      const auto& x = rows[i];
      const double var = x.sigma_m * x.sigma_m + b * b * x.truth_sigma_m * x.truth_sigma_m;
      const double w = 1 / std::max(var, 1e-12);
      const Eigen::Vector2d g(1, x.truth_m);
      N += w * g * g.transpose();
      r += w * g * x.range_m;
    }
    if (std::abs(N.determinant()) < 1e-30) return l;
    l.cov = N.inverse();
    const Eigen::Vector2d p = l.cov * r;
    l.a = p[0];
    l.b = b = p[1];
  }
  l.chi2 = 0;
  for (int i = 0; i < static_cast<int>(rows.size()); ++i) {
    if (i == skip) continue;
    const auto& x = rows[i];
    const double var = x.sigma_m * x.sigma_m + l.b * l.b * x.truth_sigma_m * x.truth_sigma_m;
    const double e = x.range_m - l.a - l.b * x.truth_m;
    l.chi2 += e * e / std::max(var, 1e-12);
  }
  l.ok = std::isfinite(l.a) && std::isfinite(l.b) && l.b > 0;
  return l;
}

}  // namespace

DatumFit FitDatum(const std::vector<DatumFitRow>& rows) {
  DatumFit f;
  f.num_rows = static_cast<int>(rows.size());
  if (rows.size() < 3) {
    f.message = std::to_string(rows.size()) + " rows with a truth and a confident range: at least 3 are needed";
    return f;
  }
  const Line l = FitLine(rows, -1);
  if (!l.ok) {
    f.message = "the truths do not span a range (all equal?) or the fit failed";
    return f;
  }
  f.dof = f.num_rows - 2;
  f.chi2 = l.chi2;
  f.chi2_per_dof = f.dof > 0 ? l.chi2 / f.dof : 0;
  const double scale = std::max(1.0, std::sqrt(f.chi2_per_dof));
  f.a_m = l.a;
  f.b = l.b;
  f.sigma_a_m = std::sqrt(l.cov(0, 0)) * scale;
  f.sigma_b = std::sqrt(l.cov(1, 1)) * scale;
  f.correlation = l.cov(0, 1) / std::sqrt(l.cov(0, 0) * l.cov(1, 1));
  double sb = 0, sa = 0, sl = 0;
  int nl = 0;
  for (int i = 0; i < f.num_rows; ++i) {
    const auto& x = rows[i];
    const double before = std::abs(x.range_m - x.truth_m) / x.truth_m;
    const double after_m = f.Corrected(x.range_m);
    const double after = std::abs(after_m - x.truth_m) / x.truth_m;
    f.after_m.push_back(after_m);
    sb += before;
    sa += after;
    f.max_abs_rel_before = std::max(f.max_abs_rel_before, before);
    f.max_abs_rel_after = std::max(f.max_abs_rel_after, after);
    double loo_m = std::numeric_limits<double>::quiet_NaN();
    if (f.num_rows >= 4) {
      const Line k = FitLine(rows, i);
      if (k.ok) {
        loo_m = (x.range_m - k.a) / k.b;
        const double e = std::abs(loo_m - x.truth_m) / x.truth_m;
        sl += e;
        ++nl;
        f.max_abs_rel_loo = std::max(f.max_abs_rel_loo, e);
      }
    }
    f.loo_m.push_back(loo_m);
  }
  f.mean_abs_rel_before = sb / f.num_rows;
  f.mean_abs_rel_after = sa / f.num_rows;
  f.mean_abs_rel_loo = nl ? sl / nl : std::numeric_limits<double>::quiet_NaN();
  if (nl == 0) f.max_abs_rel_loo = std::numeric_limits<double>::quiet_NaN();
  f.ok = true;
  return f;
}

}  // namespace owlcal::fitting
