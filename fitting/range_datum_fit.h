#pragma once
// Datum and scale of the true distances (distance = a + b * truth): ranges that read short by a
// roughly constant amount at every distance say the tape was zeroed somewhere else than the
// cameras' optical centres (the kit2020 distance set reads 2-5 % short at 30-60 cm and within 1.5 %
// beyond 1 m: about 1.5 cm of datum, docs/conventions.md, Facts); a constant percentage says scale
// (focal length times baseline). The fit separates the two and reports the errors both before it
// and after it, in-sample and leave-one-out (each row corrected by a fit on the others).
//
// Weighted least squares over the rows with status ok and a truth: each row's variance is
// sigma_range^2 + b^2 sigma_truth^2 (iterated on b); a and b carry sigma from the covariance,
// scaled by sqrt(chi2/dof) when that exceeds 1 (the rows scatter more than their sigma).
// Corrected distance of a measured range r: (r - a) / b.
#include <string>
#include <vector>

namespace owlcal::fitting {

struct DatumFitRow {
  double range_m = 0, truth_m = 0;
  double sigma_m = 0;        // predicted sigma of the range
  double truth_sigma_m = 0;  // sigma of the logged truth
};

struct DatumFit {
  bool ok = false;
  std::string message;
  int num_rows = 0;
  double a_m = 0, b = 1, sigma_a_m = 0, sigma_b = 0, correlation = 0;
  double chi2 = 0, chi2_per_dof = 0;
  int dof = 0;
  // |error| / truth over the rows: before the fit, after it (in-sample), leave-one-out.
  double mean_abs_rel_before = 0, max_abs_rel_before = 0;
  double mean_abs_rel_after = 0, max_abs_rel_after = 0;
  double mean_abs_rel_loo = 0, max_abs_rel_loo = 0;
  std::vector<double> after_m;  // corrected range per row
  std::vector<double> loo_m;    // leave-one-out corrected range per row (NaN if not possible)
  double Corrected(double range_m) const { return (range_m - a_m) / b; }
};

// At least 3 rows (4 for leave-one-out) with distinct truths.
DatumFit FitDatum(const std::vector<DatumFitRow>& rows);

}  // namespace owlcal::fitting
