#include "reports/vergence_log_tables.h"

#include <algorithm>
#include <optional>
#include <sstream>

#include "fitting/format.h"

namespace owlcal::reports {

using fitting::FixedOrDash;

std::string VergenceReportMarkdown(const std::vector<fitting::VergenceLogRow>& rows,
                                   const fitting::VergenceLogFit& fit,
                                   const fitting::LooSummary& loo) {
  std::ostringstream md;
  md << "# Vergence log fit\n\n";
  md << rows.size() << " rows, " << fit.runs.size() << " run(s); PWM residual sigma "
     << FixedOrDash(fit.residual_sigma_us, 2) << " us; solver: " << fit.summary.termination
     << (fit.summary.usable ? "" : " (NOT usable)") << "\n\n";
  if (fit.summary.termination != "CONVERGENCE") {
    // A failed solve stops somewhere that is not a fit: no value is printed as if it were one.
    md << "The solver did not converge (" << fit.summary.message << "): no parameter is reported.\n";
    return md.str();
  }
  md << "| parameter | value | sigma | unit | note |\n|---|---|---|---|---|\n";
  for (const auto& p : fit.parameters)
    md << "| " << p.name << " | " << FixedOrDash(p.value, 3) << " | "
       << (p.determined ? FixedOrDash(p.sigma, 3) : "not determined") << " | " << p.unit << " | " << p.note << " |\n";
  if (!fit.notes.empty()) {
    md << "\nNotes:\n";
    for (const auto& n : fit.notes) md << "- " << n << "\n";
  }
  // Rows that dominate the fit: the largest whitened residuals.
  std::vector<fitting::VergenceRowDiagnostic> d = fit.rows;
  std::sort(d.begin(), d.end(), [](auto& a, auto& b) { return a.chi2 > b.chi2; });
  double total = 0;
  for (const auto& x : d) total += x.chi2;
  md << "\n## Rows that dominate chi2 (whitened PWM residuals)\n\n"
     << "| row | run | true (cm) | Rx res | Lx res | share of chi2 | range change per 1 us (cm) |\n"
     << "|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < std::min<size_t>(5, d.size()); ++i) {
    const auto& r = rows[d[i].row];
    md << "| " << d[i].row << " | " << r.run << " | " << FixedOrDash(r.true_distance_m * 100, 0) << " | "
       << FixedOrDash(d[i].residual_rx, 2) << " | " << FixedOrDash(d[i].residual_lx, 2) << " | "
       << FixedOrDash(100 * d[i].chi2 / total, 1) << " % | " << FixedOrDash(d[i].range_per_us_m * 100, 2) << " |\n";
  }
  if (loo.rows.empty()) {
    md << "\nNo leave-one-out comparison: the fit is not usable.\n";
    return md.str();
  }
  md << "\n## Leave-one-out range error" << (loo.has_fixed ? " vs a fixed-constant method" : "") << "\n\n";
  if (loo.has_fixed)
    md << "Fixed constants: " << loo.fixed_source << ".\n\n";
  else
    md << "No constants of this robot were given (--constants ROBOT-FILE), so there is no fixed-constant "
          "comparison: another robot's constants say nothing about this one.\n\n";
  md << "| | mean abs error | median abs error | no fix |\n|---|---|---|---|\n";
  if (loo.has_fixed)
    md << "| fixed constants | " << FixedOrDash(100 * loo.fixed_mean_abs_rel, 1) << " % | "
       << FixedOrDash(100 * loo.fixed_median_abs_rel, 1) << " % | " << loo.fixed_failures << " |\n";
  md << "| fitted maps (leave-one-out) | " << FixedOrDash(100 * loo.loo_mean_abs_rel, 1) << " % | "
     << FixedOrDash(100 * loo.loo_median_abs_rel, 1) << " % | " << loo.loo_failures << " |\n\n"
     << "(a row without a fix, or off by more than 100 %, counts as 100 %)\n";
  if (loo.folds > 0 && static_cast<size_t>(loo.folds) < rows.size())
    md << "\nThe log has " << rows.size() << " rows, so they were dealt into " << loo.folds
       << " folds (row i in fold i mod " << loo.folds
       << ") and each row was predicted by a fit without its fold, not without it alone.\n";
  return md.str();
}

std::string VergenceRowsCsv(const std::vector<fitting::VergenceLogRow>& rows,
                            const fitting::VergenceLogFit& fit,
                            const fitting::LooSummary& loo) {
  std::ostringstream c;
  c << "row,run,true_cm,Rx_us,Lx_us,fixed_cm,loo_cm,fit_cm,res_rx,res_lx,chi2,cm_per_us\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& r = rows[i];
    auto cm = [](const std::optional<double>& v) { return v ? FixedOrDash(*v * 100, 2) : std::string(""); };
    const auto fitted = fit.maps.Distance(r.rx_us, r.lx_us);
    const fitting::LooRow* l = i < loo.rows.size() ? &loo.rows[i] : nullptr;
    const fitting::VergenceRowDiagnostic& d = fit.rows[i];
    c << i << "," << r.run << "," << FixedOrDash(r.true_distance_m * 100, 2) << "," << r.rx_us << "," << r.lx_us << ","
      << (l ? cm(l->fixed_m) : "") << "," << (l ? cm(l->loo_m) : "") << "," << cm(fitted) << ","
      << FixedOrDash(d.residual_rx, 3) << "," << FixedOrDash(d.residual_lx, 3) << "," << FixedOrDash(d.chi2, 3) << ","
      << FixedOrDash(d.range_per_us_m * 100, 3) << "\n";
  }
  return c.str();
}

}  // namespace owlcal::reports
