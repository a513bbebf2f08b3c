#pragma once
// Shared helpers for the model tests: autodiff Jacobians against a careful central
// difference.
#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <ceres/cost_function.h>

namespace owlcal::models::testing {

// Compares the Jacobians `cost` reports (autodiff) with a central difference at `params`:
// step h_i = step * max(1, |x_i|), Richardson-extrapolated from h and h/2 (error O(h^4)).
// A component passes when
//   |autodiff - numeric| <= relative * max(|autodiff|, |numeric|) + absolute,
// the absolute floor covering derivatives so small that any finite difference is noise.
// Returns "" on agreement, else one line per bad component.
inline std::string GradientCheck(const ceres::CostFunction& cost,
                                 const std::vector<const double*>& params,
                                 double relative = 1e-6,
                                 double absolute = 1e-8,
                                 double step = 1e-4) {
  const std::vector<int32_t>& sizes = cost.parameter_block_sizes();
  const int m = cost.num_residuals();
  std::vector<std::vector<double>> x(sizes.size());
  std::vector<const double*> ptrs(sizes.size());
  std::vector<std::vector<double>> jac(sizes.size());
  std::vector<double*> jac_ptrs(sizes.size());
  for (size_t b = 0; b < sizes.size(); ++b) {
    x[b].assign(params[b], params[b] + sizes[b]);
    ptrs[b] = x[b].data();
    jac[b].resize(size_t(m) * sizes[b]);
    jac_ptrs[b] = jac[b].data();
  }
  std::vector<double> r0(m), rp(m), rm(m);
  if (!cost.Evaluate(ptrs.data(), r0.data(), jac_ptrs.data())) return "cost function failed to evaluate";
  auto diff = [&](size_t b, int i, double h, std::vector<double>* d) {
    const double keep = x[b][i];
    x[b][i] = keep + h;
    const bool ok1 = cost.Evaluate(ptrs.data(), rp.data(), nullptr);
    x[b][i] = keep - h;
    const bool ok2 = cost.Evaluate(ptrs.data(), rm.data(), nullptr);
    x[b][i] = keep;
    for (int r = 0; r < m; ++r) (*d)[r] = (rp[r] - rm[r]) / (2 * h);
    return ok1 && ok2;
  };
  std::ostringstream bad;
  std::vector<double> d1(m), d2(m);
  for (size_t b = 0; b < sizes.size(); ++b) {
    for (int i = 0; i < sizes[b]; ++i) {
      const double h = step * std::max(1.0, std::abs(x[b][i]));
      if (!diff(b, i, h, &d1) || !diff(b, i, h / 2, &d2)) {
        bad << "block " << b << " col " << i << ": cost fails near the point\n";
        continue;
      }
      for (int r = 0; r < m; ++r) {
        const double numeric = (4 * d2[r] - d1[r]) / 3;  // Richardson
        const double a = jac[b][size_t(r) * sizes[b] + i];
        const double err = std::abs(a - numeric);
        const double tol = relative * std::max(std::abs(a), std::abs(numeric)) + absolute;
        if (!(err <= tol)) {
          bad << "block " << b << " row " << r << " col " << i << ": autodiff " << a << " numeric " << numeric << "\n";
        }
      }
    }
  }
  return bad.str();
}

}  // namespace owlcal::models::testing
