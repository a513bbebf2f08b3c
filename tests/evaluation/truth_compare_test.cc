#include "evaluation/truth_compare.h"

#include <cmath>

#include <gtest/gtest.h>

#include "models/head_model.h"

namespace owlcal::evaluation {
namespace truth_compare_test {

fitting::Parameter P(const std::string& name, double value, double sigma, bool determined = true) {
  fitting::Parameter p;
  p.name = name;
  p.value = value;
  p.sigma = sigma;
  p.unit = "px";
  p.determined = determined;
  return p;
}

TEST(TruthCompare, FillsTruthAndCountsSigmas) {
  fitting::CalibrationResult r;
  r.Set(P("left.fx", 581.0, 0.5));  // z = +2
  r.Set(P("left.fy", 579.0, 0.5));  // z = -2 (within)
  r.Set(P("left.cx", 330.0, 1.0));  // z = +10
  r.Set(P("left.k3", 0.0, NAN, false));
  r.Set(P("head.extra", 1.0, 0.1));  // no truth
  const int n = FillTruth({{"left.fx", 580}, {"left.fy", 580}, {"left.cx", 320}, {"left.k3", 0.1}}, &r);
  EXPECT_EQ(n, 4);
  const TruthComparison c = CompareWithTruth(r);
  ASSERT_EQ(c.rows.size(), 4u);
  EXPECT_EQ(c.num_with_sigma, 3);
  EXPECT_NEAR(c.rows[0].z, 2.0, 1e-12);
  EXPECT_TRUE(c.rows[0].within_2sigma);
  EXPECT_NEAR(c.fraction_within_2sigma, 2.0 / 3.0, 1e-12);
  EXPECT_EQ(c.worst, "left.cx");
  EXPECT_NEAR(c.worst_z, 10.0, 1e-12);
  EXPECT_NEAR(c.rms_z, std::sqrt((4 + 4 + 100) / 3.0), 1e-12);
  EXPECT_TRUE(std::isnan(c.rows[3].z));
  ASSERT_EQ(c.missing_truth.size(), 1u);
  EXPECT_EQ(c.missing_truth[0], "head.extra");
  // Existing truth is kept unless overwrite.
  EXPECT_EQ(FillTruth({{"left.fx", 1}}, &r), 0);
  EXPECT_EQ(FillTruth({{"left.fx", 1}}, &r, true), 1);
}

TEST(TruthCompare, StereoTruthOfTheNominalHeadIsTheIpd) {
  const models::RobotConfig cfg = models::DefaultRobotConfig();
  const models::HeadModel head = models::NominalHeadModel(cfg);
  const auto s = StereoTruthValues(head, cfg.Centre());
  // Parallel eyes 65 mm apart: x_right = x_left - 65 mm.
  EXPECT_NEAR(s.at("stereo.baseline_mm"), 65.0, 1e-9);
  EXPECT_NEAR(s.at("stereo.tx"), -65.0, 1e-9);
  EXPECT_NEAR(s.at("stereo.ry_deg"), 0.0, 1e-9);
  // Converging the right eye by 1 deg (Rx down) rotates right_from_left about y.
  models::PwmVector pwm = cfg.Centre();
  pwm[models::kRx] -= 100;
  const auto s2 = StereoTruthValues(head, pwm);
  EXPECT_NEAR(std::abs(s2.at("stereo.ry_deg")), 11.3, 1e-6);
  const auto in = IntrinsicsTruthValues(head);
  EXPECT_DOUBLE_EQ(in.at("right.fx"), 585.0);
  EXPECT_DOUBLE_EQ(in.at("left.k3"), 0.0);
}

// A rational truth lens fitted with the 5-coefficient model: no coefficient is compared with a
// coefficient of the other model; the projection difference says how well it is modelled, and it
// is larger for a worse fit.
TEST(TruthCompare, ALensOfAnotherModelIsComparedByProjection) {
  models::HeadModel truth = models::NominalHeadModel(models::DefaultRobotConfig());
  truth.intrinsics[0].model = models::DistortionModel::kOpenCv8;
  truth.intrinsics[0].params = {520, 520, 320, 240, 0.4, -0.1, 0, 0, 0, 0.7, -0.05, 0};
  models::CameraIntrinsics near = truth.intrinsics[1];  // the right eye: same model as its truth
  models::CameraIntrinsics fit5;
  fit5.params = {520, 520, 320, 240, -0.28, 0.07, 0, 0, -0.01};  // the rational lens' barrel, roughly
  fitting::CalibrationResult r;
  for (const char* n : {"left.fx", "left.k1", "head.left.k1", "right.fx"}) r.Set(P(n, 1.0, 0.1));
  FillTruth({{"left.fx", 520}, {"left.k1", 0.4}, {"head.left.k1", 0.4}, {"right.fx", 585}}, &r);
  EXPECT_EQ(CompareLensByProjection(truth, {&fit5, &near}, {"", "head."}, &r), 1);
  EXPECT_FALSE(r.Find("left.fx")->truth);
  EXPECT_FALSE(r.Find("left.k1")->truth);
  EXPECT_FALSE(r.Find("head.left.k1")->truth);
  EXPECT_TRUE(r.Find("right.fx")->truth);  // same model: compared as before
  const nlohmann::json& j = r.diagnostics.at("lens_truth").at("left");
  EXPECT_EQ(j.at("fitted_model"), "opencv5");
  EXPECT_EQ(j.at("truth_model"), "opencv8");
  ASSERT_TRUE(j.at("ok").get<bool>()) << j.dump();
  const double rough = j.at("rms_px").get<double>();
  EXPECT_GT(rough, 0.0);
  EXPECT_LE(j.at("inner_rms_px").get<double>(), rough + 1e-9);
  EXPECT_FALSE(r.diagnostics.at("lens_truth").contains("right"));
  // A worse fit shows as a larger projection difference.
  models::CameraIntrinsics worse = fit5;
  worse.params[4] = 0;
  fitting::CalibrationResult r2;
  CompareLensByProjection(truth, {&worse, nullptr}, {""}, &r2);
  EXPECT_GT(r2.diagnostics.at("lens_truth").at("left").at("rms_px").get<double>(), rough);
}

}  // namespace truth_compare_test
}  // namespace owlcal::evaluation
