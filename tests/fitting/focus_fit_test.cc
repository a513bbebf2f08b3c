// The depth-of-field fit recovers a known lens (in-focus blur, defocus per dioptre, focus) from
// noisy blur-vs-distance samples, with sigmas that cover the errors; it says so when the data
// show no defocus, and refuses too few distances.
#include "fitting/focus_fit.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

const std::vector<double> kDistances = {0.2, 0.25, 0.3, 0.35, 0.4, 0.5, 0.6, 0.7, 0.8, 1.0, 1.25, 1.5, 1.75, 2.0};

std::vector<FocusSample> Samples(double s0, double k, double xf, double se, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0, se);
  std::vector<FocusSample> out;
  for (const double d : kDistances) {
    const double u = 1 / d - xf;
    out.push_back({d, std::sqrt(s0 * s0 + k * k * u * u) + n(rng), se});
  }
  return out;
}

TEST(FocusFit, RecoversAKnownLensWithHonestSigmas) {
  // The course's Pi lens at 640 px: 1.25 mm pupil, fx 583 px -> k = 0.18 px/D; focus 0.56 m.
  const double s0 = 0.6, k = 1.25e-3 * 583 / 4, xf = 1 / 0.56;
  int within = 0, n = 0;
  for (uint64_t seed = 1; seed <= 40; ++seed) {
    const FocusFit f = FitFocus(Samples(s0, k, xf, 0.01, seed));
    ASSERT_TRUE(f.ok) << f.reason;
    ASSERT_TRUE(f.focus_found);
    EXPECT_EQ(f.num_samples, 14);
    for (const auto& [v, t, s] : {std::tuple{f.s0_px, s0, f.s0_sigma_px},
                                  std::tuple{f.k_px_per_dioptre, k, f.k_sigma},
                                  std::tuple{f.focus_dioptre, xf, f.focus_dioptre_sigma}}) {
      EXPECT_LT(std::abs(v - t), 4 * s) << "seed " << seed;
      within += std::abs(v - t) < 2 * s;
      ++n;
    }
  }
  EXPECT_GE(within, int(0.88 * n));  // 95 % expected within 2 sigma
  const FocusFit f = FitFocus(Samples(s0, k, xf, 0.01, 7));
  EXPECT_NEAR(f.focus_m, 0.56, 0.06);
  EXPECT_NEAR(f.Predict(0.3), std::sqrt(s0 * s0 + k * k * std::pow(1 / 0.3 - xf, 2)), 0.02);
  // Depth of field at blur <= sqrt 2 s0: |1/d - x_f| <= s0 / k.
  double near_m, far_m;
  DepthOfField(s0, k, xf, std::sqrt(2.0), &near_m, &far_m);
  EXPECT_NEAR(near_m, 1 / (xf + s0 / k), 1e-12);
  EXPECT_TRUE(std::isinf(far_m));  // s0 / k > x_f: sharp to infinity
  EXPECT_NEAR(f.dof_near_m, near_m, 3 * f.dof_near_sigma_m + 1e-9);
  EXPECT_GT(f.dof_near_sigma_m, 0);
}

TEST(FocusFit, AFiniteFarLimitWhenFocusedClose) {
  const double s0 = 0.4, k = 0.3, xf = 4;  // focused at 0.25 m
  const FocusFit f = FitFocus(Samples(s0, k, xf, 0.01, 3));
  ASSERT_TRUE(f.ok && f.focus_found) << f.reason;
  double near_m, far_m;
  DepthOfField(s0, k, xf, std::sqrt(2.0), &near_m, &far_m);
  ASSERT_TRUE(std::isfinite(far_m));
  EXPECT_NEAR(f.dof_far_m, far_m, 3 * f.dof_far_sigma_m);
  EXPECT_NEAR(f.dof_near_m, near_m, 3 * f.dof_near_sigma_m);
}

TEST(FocusFit, NoDefocusMeansNoFocus) {
  std::vector<FocusSample> flat = Samples(0.5, 0, 0, 0.01, 5);
  const FocusFit f = FitFocus(flat);
  ASSERT_TRUE(f.ok) << f.reason;
  EXPECT_FALSE(f.focus_found);
  EXPECT_TRUE(std::isinf(f.focus_m));
  EXPECT_DOUBLE_EQ(f.dof_near_m, 0.2);
  EXPECT_DOUBLE_EQ(f.dof_far_m, 2.0);
  // s0 alone is not determined then (a far-away focus with some defocus fits as well); the
  // predicted blur is.
  for (const double d : {0.2, 0.7, 2.0}) EXPECT_NEAR(f.Predict(d), 0.5, 0.01) << d;
}

TEST(FocusFit, RefusesTooFewDistancesAndBadOptions) {
  const std::vector<FocusSample> three = {{0.3, 0.5, 0.01}, {0.5, 0.4, 0.01}, {1.0, 0.45, 0.01}, {1.0, 0.46, 0.01}};
  FocusFit f = FitFocus(three);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.reason.find("too few distances: 3"), std::string::npos) << f.reason;
  FocusFitOptions o;
  o.dof_blur_ratio = 1;
  f = FitFocus(Samples(0.5, 0.2, 2, 0.01, 1), o);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.reason.find("dof_blur_ratio"), std::string::npos) << f.reason;
}

}  // namespace
}  // namespace owlcal::fitting
