// The bring-up's reading of the limits protocol's rows (pipeline/bring_up.h): directions from the
// image motion's sign, a mirrored stream named instead of three reversed servos, and the measured
// stops minus the margin as the limits every later protocol keeps to.
#include "pipeline/bring_up.h"

#include <gtest/gtest.h>

#include "calib/trial_status.h"

namespace owlcal::pipeline {
namespace {

// The limits rows of a robot whose image moves as the file's directions say, every end at the
// configured limit.
std::vector<protocols::LimitRow> AgreeingRows(const models::RobotConfig& c) {
  std::vector<protocols::LimitRow> rows;
  for (int s = 0; s < models::kNumServos; ++s)
    for (const char* end : {"min", "max"}) {
      protocols::LimitRow r;
      r.servo = models::kServoNames[s];
      r.end = end;
      r.configured_us = end[1] == 'i' ? c.servos[s].min_us : c.servos[s].max_us;
      r.measured_us = r.configured_us;
      r.cause = "configured";
      const int image_sign = (s == models::kRy || s == models::kLy) ? +1 : -1;
      r.image_px_per_us = 1.2 * image_sign * c.servos[s].direction;
      r.status = calib::TrialStatus::kOk;
      rows.push_back(r);
    }
  return rows;
}

// A stop off pigpio's 5 us grid: the limit used is the stop minus the margin, rounded inward to
// the grid, so that the servo sweep's "min+30" is a pulse a 5 us servo applies as commanded (off
// the grid, the reassembled robot's neck map came out with its quadratic term 8 sigma off).
TEST(BringUp, LearnedLimitsAreOnTheFiveMicrosecondGrid) {
  const models::RobotConfig c = models::DefaultRobotConfig();
  std::vector<protocols::LimitRow> rows = AgreeingRows(c);
  for (auto& r : rows) {
    if (r.servo == "Neck" && r.end == "min") r.measured_us = 1163, r.cause = "end-stop";
    if (r.servo == "Neck" && r.end == "max") r.measured_us = 1878, r.cause = "end-stop";
  }
  const BringUp b = LearnFromLimits(c, rows, 10);
  EXPECT_EQ(b.learned.servos[models::kNeck].min_us, 1180);  // 1163 + 15 = 1178, inward to 1180
  EXPECT_EQ(b.learned.servos[models::kNeck].max_us, 1860);  // 1878 - 15 = 1863, inward to 1860
  ASSERT_EQ(b.findings.size(), 2u);
  EXPECT_EQ(b.findings[0],
            "Neck low limit: your robot file says 1100 us; end-stop measured at 1163 us; used 1180 us (17 us inside)");
}

TEST(BringUp, ARobotAsItsFileSaysChangesNothing) {
  const models::RobotConfig c = models::DefaultRobotConfig();
  const BringUp b = LearnFromLimits(c, AgreeingRows(c));
  EXPECT_FALSE(b.Changed());
  EXPECT_TRUE(b.findings.empty());
  EXPECT_TRUE(b.notes.empty()) << b.notes.front();
}

TEST(BringUp, AReversedHornAndStopsInsideTheLimitsAreLearned) {
  const models::RobotConfig c = models::DefaultRobotConfig();
  std::vector<protocols::LimitRow> rows = AgreeingRows(c);
  for (auto& r : rows) {
    if (r.servo == "Ly") *r.image_px_per_us = -*r.image_px_per_us;  // the horn put back reversed
    if (r.servo == "Neck" && r.end == "max") r.measured_us = 1880, r.cause = "end-stop";
    if (r.servo == "Neck" && r.end == "min") r.measured_us = 1160, r.cause = "end-stop";
  }
  const BringUp b = LearnFromLimits(c, rows, 10);
  EXPECT_TRUE(b.Changed());
  EXPECT_EQ(b.learned.servos[models::kLy].direction, +1);
  EXPECT_EQ(b.file.servos[models::kLy].direction, -1);
  EXPECT_EQ(b.learned.servos[models::kRy].direction, c.servos[models::kRy].direction);
  // The stop minus the margin and the search's 5 us error (evaluation/limits_eval.h).
  EXPECT_EQ(b.learned.servos[models::kNeck].max_us, 1880 - 15);
  EXPECT_EQ(b.learned.servos[models::kNeck].min_us, 1160 + 15);
  EXPECT_EQ(b.learned.servos[models::kRx].max_us, c.servos[models::kRx].max_us);
  ASSERT_EQ(b.findings.size(), 3u);
  EXPECT_EQ(b.findings[0], "your robot file says -1 for Ly; the robot turns +1; used +1");
  const nlohmann::json j = b.ToJson();
  EXPECT_TRUE(j.at("changed").get<bool>());
  EXPECT_EQ(j.at("servos")[models::kLy].at("used").at("direction"), 1);
}

TEST(BringUp, AMirroredStreamIsNamedNotTakenForThreeReversedServos) {
  const models::RobotConfig c = models::DefaultRobotConfig();
  std::vector<protocols::LimitRow> rows = AgreeingRows(c);
  for (auto& r : rows)
    if (r.servo == "Rx" || r.servo == "Lx" || r.servo == "Neck") *r.image_px_per_us = -*r.image_px_per_us;
  const BringUp b = LearnFromLimits(c, rows);
  EXPECT_FALSE(b.Changed());
  ASSERT_EQ(b.findings.size(), 1u);
  EXPECT_NE(b.findings[0].find("mirrored"), std::string::npos) << b.findings[0];
}

TEST(BringUp, AnUnmeasuredServoKeepsTheFileAndSaysSo) {
  const models::RobotConfig c = models::DefaultRobotConfig();
  std::vector<protocols::LimitRow> rows = AgreeingRows(c);
  for (auto& r : rows)
    if (r.servo == "Ry") r.status = calib::TrialStatus::kFailed, r.measured_us.reset(), r.image_px_per_us = 0.0;
  const BringUp b = LearnFromLimits(c, rows);
  EXPECT_FALSE(b.Changed());
  bool named = false;
  for (const auto& n : b.notes) named |= n.rfind("Ry: direction not measured", 0) == 0;
  EXPECT_TRUE(named);
  EXPECT_EQ(b.learned.servos[models::kRy].min_us, c.servos[models::kRy].min_us);
}

}  // namespace
}  // namespace owlcal::pipeline
