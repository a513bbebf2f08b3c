#include <cmath>
#include <random>
#include <stdexcept>

#include <gtest/gtest.h>

#include "fitting/monte_carlo.h"

namespace owlcal::fitting {
namespace {

// The mean of N Gaussian samples, reported with sigma / sqrt(N): an honest estimator.
std::vector<Parameter> MeanFit(uint64_t seed, double sigma_scale) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 2.0);
  const double truth = 10.0;
  double sum = 0;
  const int n = 25;
  for (int i = 0; i < n; ++i) sum += truth + noise(rng);
  Parameter p;
  p.name = "mean";
  p.value = sum / n;
  p.sigma = sigma_scale * 2.0 / std::sqrt(double(n));
  p.truth = truth;
  Parameter undetermined = p;
  undetermined.name = "gauge";
  undetermined.determined = false;  // never scored
  undetermined.sigma = std::nan("");
  return {p, undetermined};
}

TEST(MonteCarlo, HonestSigmaCoversAboutSixtyEightPercent) {
  const SigmaCoverage c = RunMonteCarlo(400, 1, [](uint64_t s) { return MeanFit(s, 1.0); });
  EXPECT_EQ(c.num_fits(), 400);
  EXPECT_EQ(c.num_scored(), 400);
  EXPECT_NEAR(c.FractionWithin(1), 0.683, 0.05);
  EXPECT_GE(c.FractionWithin(3), 0.99);
  EXPECT_NE(c.Report().find("mean"), std::string::npos);
  EXPECT_EQ(c.Report().find("gauge"), std::string::npos);
}

TEST(MonteCarlo, OptimisticSigmaIsCaught) {
  const SigmaCoverage c = RunMonteCarlo(400, 1, [](uint64_t s) { return MeanFit(s, 0.4); });
  EXPECT_LT(c.FractionWithin(1), 0.45);
  EXPECT_GT(c.per_parameter().at("mean").sum_z2 / 400, 4.0);
}

TEST(MonteCarlo, FailuresAreCountedNotScored) {
  const SigmaCoverage c = RunMonteCarlo(10, 0, [](uint64_t s) -> std::vector<Parameter> {
    if (s % 2) throw std::runtime_error("diverged");
    return MeanFit(s, 1.0);
  });
  EXPECT_EQ(c.num_fits(), 10);
  EXPECT_EQ(c.num_failures(), 5);
  EXPECT_EQ(c.num_scored(), 5);
  EXPECT_NE(c.Report().find("seed 1: diverged"), std::string::npos);
}

// The bench scores a second head fit (the fused one) and the servo maps' errors at their range
// ends as their own groups beside the calibration's, without counting them as more fits.
TEST(MonteCarlo, SuffixedFitsAreTheirOwnGroups) {
  SigmaCoverage c;
  Parameter scale{"servo.Rx.deg_per_us", 0.11305, 0.0001, "deg/us", 0.1130, true, ""};
  Parameter end{"servo_end.Rx.max", 0.02, 0.005, "deg", 0.0, true, ""};
  c.Add({scale});
  scale.value = 0.1126;  // 4 sigma off in the second fit
  c.Add({scale, end}, " (fused)");
  EXPECT_EQ(c.num_fits(), 1);
  EXPECT_EQ(c.num_scored(), 3);
  ASSERT_EQ(c.per_group().size(), 3u);
  EXPECT_EQ(c.per_group().at("servo maps").within1, 1);
  EXPECT_EQ(c.per_group().at("servo maps (fused)").within3, 0);
  EXPECT_EQ(c.per_group().at("servo ends (fused)").within3, 0);  // 4 sigma
  EXPECT_EQ(c.per_group().at("servo maps (fused)").worst, "servo.Rx.deg_per_us (fused)");
  EXPECT_TRUE(c.per_parameter().count("servo_end.Rx.max (fused)"));
}

}  // namespace
}  // namespace owlcal::fitting
