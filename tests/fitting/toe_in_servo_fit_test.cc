// Eye-pan servo maps from stereo calibrations at known PWM (fitting/toe_in_servo_fit.h), on
// synthetic sets with known truth: observations of a board seen by two cameras whose pan
// follows the truth maps, each set calibrated by the same code a user's folder goes through
// (CalibrateImageSet), with servo repeatability added per set.
#include "fitting/toe_in_servo_fit.h"

#include <iostream>
#include <random>

#include <gtest/gtest.h>
#include <Eigen/Geometry>

#include "evaluation/range_images_calib.h"
#include "reports/toe_in_tables.h"
#include "tests/fitting/toe_in_synthetic.h"

namespace owlcal::fitting {
namespace toe_in_servo_fit_test {

using test_toe_in::kDeg;
using test_toe_in::kSettings;
using test_toe_in::SynthesiseSet;
using test_toe_in::Truth;

std::vector<ToeInSet> CalibratedSets(const Truth& t, unsigned seed) {
  std::mt19937 rng(seed);
  std::vector<ToeInSet> sets;
  for (size_t i = 0; i < kSettings.size(); ++i) {
    const auto obs = SynthesiseSet(t, kSettings[i].rx, kSettings[i].lx, &rng);
    StereoFitOptions o;
    const evaluation::ImageSetCalibration c = evaluation::CalibrateImageSet(obs, o);
    EXPECT_TRUE(c.fit.ok) << c.fit.message;
    ToeInSet s = ToeInSetFromResult(c.result, "set" + std::to_string(i));
    s.rx_us = kSettings[i].rx;
    s.lx_us = kSettings[i].lx;
    s.ry_us = 1530;
    s.ly_us = 1580;
    sets.push_back(s);
  }
  return sets;
}

TEST(ToeInServoFit, RecoversEachEyesScaleWithinSigmaAndReportsTheScatter) {
  const Truth t;
  const auto sets = CalibratedSets(t, 5);
  const ToeInServoFit fit = FitToeIn(sets);
  std::cout << reports::ToeInMarkdown(sets, fit);
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_TRUE(fit.per_eye);
  EXPECT_EQ(fit.num_sets, 8);
  EXPECT_EQ(fit.dof, 5);
  // Truth within 3 sigma, and sigma honest (not inflated beyond use).
  EXPECT_NEAR(fit.rx_deg_per_us, t.rx_deg_per_us, 3 * fit.rx_sigma);
  EXPECT_NEAR(fit.lx_deg_per_us, t.lx_deg_per_us, 3 * fit.lx_sigma);
  EXPECT_LT(fit.rx_sigma, 0.01);
  EXPECT_LT(fit.lx_sigma, 0.01);
  // The repeatability (0.25 deg per eye, so 0.35 deg in the relative yaw) dominates the sets'
  // calibration sigma: chi2/dof far above 1 and the scatter recovered roughly.
  EXPECT_GT(fit.chi2_per_dof, 5);
  EXPECT_GT(fit.repeatability_deg, 0.1);
  EXPECT_LT(fit.repeatability_deg, 0.8);
  // The yaw at the mean PWM: truth = lx_k (mean Lx - c) - rx_k (mean Rx - c) + mount.
  double mrx = 0, mlx = 0;
  for (const auto& s : kSettings) mrx += s.rx / kSettings.size(), mlx += s.lx / kSettings.size();
  const double yaw = t.lx_deg_per_us * (mlx - t.lx_centre) - t.rx_deg_per_us * (mrx - t.rx_centre) + t.mount_yaw_deg;
  EXPECT_NEAR(fit.offset_deg, yaw, 3 * fit.offset_sigma + 0.05);
}

TEST(ToeInServoFit, SymmetricToeInOnlyGivesOneCommonScaleAndSaysSo) {
  Truth t;
  t.rx_deg_per_us = t.lx_deg_per_us = 0.094;
  std::vector<ToeInSet> sets = CalibratedSets(t, 11);
  std::vector<ToeInSet> symmetric;
  for (size_t i = 0; i < sets.size(); ++i)
    if (kSettings[i].rx + kSettings[i].lx == 3090) symmetric.push_back(sets[i]);  // Rx down = Lx up
  ASSERT_GE(symmetric.size(), 4u);
  const ToeInServoFit fit = FitToeIn(symmetric);
  std::cout << reports::ToeInMarkdown(symmetric, fit);
  ASSERT_TRUE(fit.ok) << fit.message;
  EXPECT_FALSE(fit.per_eye);
  EXPECT_NEAR(fit.rx_deg_per_us, 0.094, 3 * fit.rx_sigma);
  bool said = false;
  for (const auto& n : fit.notes) said |= n.find("only one eye moves") != std::string::npos;
  EXPECT_TRUE(said);
  ToeInFitOptions per_eye;
  per_eye.scale_mode = ScaleMode::kPerEye;
  EXPECT_FALSE(FitToeIn(symmetric, per_eye).ok);
}

TEST(ToeInServoFit, TooFewOrUnusableSetsAreRefusedWithAReason) {
  ToeInSet a;
  a.ok = true;
  a.yaw_sigma_deg = 0.02;
  std::vector<ToeInSet> two = {a, a};
  EXPECT_FALSE(FitToeIn(two).ok);
  ToeInSet bad;
  bad.name = "mirrored";
  bad.message = "the set's verdict is unusable";
  two.push_back(bad);
  const auto f = FitToeIn(two);
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.message.find("2 usable sets"), std::string::npos) << f.message;
  ASSERT_FALSE(f.notes.empty());
  EXPECT_NE(f.notes[0].find("mirrored left out"), std::string::npos) << f.notes[0];
}

}  // namespace toe_in_servo_fit_test
}  // namespace owlcal::fitting
