// Prints what fit-vergence's fit and leave-one-out comparison cost against the rows of a log:
// the cost is linear in the rows (at most kMaxVergenceFolds refits). Figures only; nothing is
// asserted.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "fitting/vergence_log_fit.h"

using namespace owlcal;
using Clock = std::chrono::steady_clock;

static double Seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

int main() {
  fitting::VergenceMaps truth;
  truth.rx_centre_us = 1452;
  truth.rx_us_per_deg = 10.1;
  truth.lx_centre_us = 1421;
  truth.lx_us_per_deg = 11.2;
  for (int n : {300, 1000, 3000, 10000, 30000}) {
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0, 0.7);
    std::vector<fitting::VergenceLogRow> rows;
    for (int i = 0; i < n; ++i) {
      const double d = 0.10 + 0.01 * (i % 91);  // 10..100 cm, one run
      double rx, lx;
      truth.PredictPwm(d, 0, &rx, &lx);
      rows.push_back({1, d, std::round(rx + noise(rng)), std::round(lx + noise(rng))});
    }
    const fitting::VergenceFitOptions o;
    const auto t0 = Clock::now();
    const fitting::VergenceLogFit fit = fitting::FitVergenceLog(rows, o);
    const auto t1 = Clock::now();
    const fitting::LooSummary loo = fitting::LeaveOneOut(rows, o, fit);
    const auto t2 = Clock::now();
    std::printf(
        "vergence fit: %6d rows: fit %.3f s, cross-validation %.3f s in %d folds (%.1f us per row), "
        "median error %.2f %%\n",
        n,
        Seconds(t1 - t0),
        Seconds(t2 - t1),
        loo.folds,
        1e6 * Seconds(t2 - t0) / n,
        100 * loo.loo_median_abs_rel);
  }
  return 0;
}
