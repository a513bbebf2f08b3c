#include "fitting/vergence_log_fit.h"

#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "tests/shared_data.h"

namespace owlcal::fitting {
namespace {

using ::owlcal::test_data::SharedData;

// Synthetic log from known maps, PWM rounded to 1 us like a real log.
std::vector<VergenceLogRow> SyntheticLog(const VergenceMaps& truth, int runs, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 0.7);
  std::vector<VergenceLogRow> rows;
  for (int r = 0; r < runs; ++r) {
    for (int cm = 10; cm <= 100; cm += 10) {
      double rx, lx;
      truth.PredictPwm(cm / 100.0, r, &rx, &lx);
      rows.push_back({r + 1, cm / 100.0, std::round(rx + noise(rng)), std::round(lx + noise(rng))});
    }
  }
  return rows;
}

TEST(VergenceLogFit, RecoversMapsAndDatumFromSyntheticLogWithinSigma) {
  VergenceMaps truth;
  truth.rx_centre_us = 1452;
  truth.rx_us_per_deg = 10.1;
  truth.lx_centre_us = 1421;
  truth.lx_us_per_deg = 11.2;
  truth.ipd_m = 0.065;
  truth.datum_offset_m = 0.045;
  truth.run_bearing_rad = {0, 0.02, -0.015};
  const auto rows = SyntheticLog(truth, 3, 7);
  VergenceFitOptions o;
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
  EXPECT_FALSE(fit.ipd_free) << "IPD should not be separable from the scales";
  auto check = [&](const std::string& name, double t) {
    for (const auto& p : fit.parameters) {
      if (p.name != name) continue;
      ASSERT_TRUE(p.determined) << name;
      EXPECT_LT(std::abs(p.value - t), 4 * p.sigma + 1e-9) << name << " = " << p.value << " +- " << p.sigma;
      EXPECT_GT(p.sigma, 0) << name;
      return;
    }
    ADD_FAILURE() << name << " missing";
  };
  check("servo.Rx.centre_us", truth.rx_centre_us);
  check("servo.Lx.centre_us", truth.lx_centre_us);
  check("servo.Rx.us_per_deg", truth.rx_us_per_deg);
  check("servo.Lx.us_per_deg", truth.lx_us_per_deg);
  check("vergence.datum_mm", truth.datum_offset_m * 1000);
  EXPECT_NEAR(fit.residual_sigma_us, 0.8, 0.3);
}

TEST(VergenceLogFit, FixedConstantMethodReproducesTheStudentsSheet) {
  // Run 1, 30 cm and 10 cm rows of noble2020 with the sheet's own estimates.
  FixedConstantVergence f;
  EXPECT_NEAR(*f.Distance(1385, 1485) * 100, 31.647, 0.01);
  EXPECT_NEAR(*f.Distance(1310, 1595) * 100, 10.051, 0.01);
  EXPECT_FALSE(f.Distance(1445, 1430).has_value()) << "parallel gaze has no fix";
}

TEST(VergenceLogFit, Noble2020LeaveOneOutBeatsFixedConstants) {
  const std::string path = SharedData() + "/owl-real/noble2020-vergence-range/vergence_runs.csv";
  const auto rows = ReadVergenceLogCsv(path);
  ASSERT_EQ(rows.size(), 30u);
  VergenceFitOptions o;
  const VergenceLogFit fit = FitVergenceLog(rows, o);
  ASSERT_TRUE(fit.summary.usable) << fit.summary.message;
  const LooSummary loo = LeaveOneOut(rows, o, fit, FixedConstantVergence{});
  std::cout << VergenceReportMarkdown(rows, fit, loo) << "\n" << VergenceRowsCsv(rows, fit, loo);
  EXPECT_LT(loo.loo_mean_abs_rel, loo.fixed_mean_abs_rel);
  EXPECT_LT(loo.loo_median_abs_rel, loo.fixed_median_abs_rel);
  for (const auto& p : fit.parameters) {
    if (p.determined) {
      EXPECT_TRUE(std::isfinite(p.sigma) && p.sigma > 0) << p.name;
    }
  }
}

TEST(VergenceLogFit, ReaderNamesFileAndFieldOnBadInput) {
  const std::string path = ::testing::TempDir() + "/bad_vergence.csv";
  {
    std::ofstream f(path);
    f << "run,distance_cm,Rx,Lx\n1,10,13x0,1595\n";
  }
  try {
    ReadVergenceLogCsv(path);
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("Rx"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace owlcal::fitting
