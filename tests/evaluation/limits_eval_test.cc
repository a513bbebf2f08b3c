#include "evaluation/limits_eval.h"

#include <cmath>

#include <gtest/gtest.h>

namespace owlcal::evaluation {
namespace {

TEST(LimitsEval, ComparesConfiguredAndMeasuredEnds) {
  const models::RobotConfig cfg = models::DefaultRobotConfig();
  const models::HeadModel head = models::NominalHeadModel(cfg);
  std::vector<LimitMeasurement> m = {
      {models::kRx, false, 1230, LimitCause::kEndStop},    // stop 30 us inside min 1200
      {models::kRx, true, 1890, LimitCause::kConfigured},  // reached the configured max
      {models::kLx, true, 1800, LimitCause::kSocketRim},   // rim 50 us inside max 1850
  };
  const LimitsEvaluation ev = EvaluateLimits(cfg, m, &head, 10, 0);
  ASSERT_EQ(ev.servos.size(), 5u);
  const ServoLimits& rx = ev.servos[models::kRx];
  EXPECT_EQ(rx.name, "Rx");
  EXPECT_DOUBLE_EQ(*rx.measured_min_us, 1230);
  EXPECT_EQ(rx.min_cause, LimitCause::kEndStop);
  EXPECT_EQ(rx.recommended_min_us, 1240);
  EXPECT_EQ(rx.recommended_max_us, 1890);  // configured end binding: unchanged
  EXPECT_DOUBLE_EQ(rx.min_excess_us, -30);
  // Angle of the measured end from the map: (1230 - 1545) * 0.113 deg.
  EXPECT_NEAR(rx.measured_min_deg, (1230 - 1545) * 0.113, 1e-9);
  const ServoLimits& lx = ev.servos[models::kLx];
  EXPECT_EQ(lx.max_cause, LimitCause::kSocketRim);
  EXPECT_EQ(lx.recommended_max_us, 1790);
  EXPECT_FALSE(ev.servos[models::kNeck].measured_min_us);
  EXPECT_TRUE(std::isnan(ev.servos[models::kNeck].measured_min_deg));
  bool noted = false;
  for (const auto& n : ev.notes)
    noted |= n.find("Lx high end: socket rim at 1800 us, 50 us inside") != std::string::npos;
  EXPECT_TRUE(noted);
  EXPECT_EQ(LimitCauseFromName("rim"), LimitCause::kSocketRim);
  EXPECT_STREQ(LimitCauseName(LimitCauseFromName("endstop")), "end-stop");
  EXPECT_THROW(EvaluateLimits(cfg, {{7, false, 1000, LimitCause::kEndStop}}, nullptr), std::invalid_argument);
  EXPECT_THROW(EvaluateLimits(cfg, m, nullptr, -1), std::invalid_argument);
}

// By default the recommended limits allow for the search's 5 us error: a stop measured at 1230 us
// may truly be at 1225 us, so 1245 us keeps the 10 us margin from it.
TEST(LimitsEval, RecommendedLimitsAllowForTheStopsMeasurementError) {
  const models::RobotConfig cfg = models::DefaultRobotConfig();
  const LimitsEvaluation ev = EvaluateLimits(
      cfg,
      {{models::kRx, false, 1230, LimitCause::kEndStop}, {models::kNeck, true, 1939, LimitCause::kEndStop}},
      nullptr);
  EXPECT_EQ(ev.servos[models::kRx].recommended_min_us, 1245);
  EXPECT_EQ(ev.servos[models::kNeck].recommended_max_us, 1924);
}

}  // namespace
}  // namespace owlcal::evaluation
