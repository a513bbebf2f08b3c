#include "fitting/robot_file_check.h"

#include <cmath>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

Parameter P(const std::string& name, double value, double sigma) {
  Parameter p;
  p.name = name;
  p.value = value;
  p.sigma = sigma;
  return p;
}

// A fit that agrees with the guide's robot file everywhere.
CalibrationResult AgreeingFit(const models::RobotConfig& robot) {
  CalibrationResult r;
  r.Set(P("head.ipd_mm", robot.ipd_m * 1000 + 0.2, 0.05));  // within the 0.5 mm tolerance
  for (int i = 0; i < models::kNumServos; ++i) {
    const auto& sc = robot.servos[i];
    const std::string n = std::string("servo.") + models::kServoNames[i];
    r.Set(P(n + ".centre_us", sc.centre_us + 4, 0.3));                // 13 sigma but within 10 us
    r.Set(P(n + ".deg_per_us", sc.nominal_deg_per_us * 1.01, 2e-5));  // 1 % off: within 3 %
  }
  return r;
}

TEST(RobotFileCheck, AFitWithinTheTolerancesIsQuietEvenWhenManySigmaAway) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  EXPECT_TRUE(CompareWithRobotFile(AgreeingFit(robot), robot).empty());
  EXPECT_TRUE(RobotFileWarnings({}).empty());
}

TEST(RobotFileCheck, NamesTheIpdCentreScaleAndDirectionThatDisagree) {
  models::RobotConfig robot = models::DefaultRobotConfig();
  CalibrationResult r = AgreeingFit(robot);
  r.Set(P("head.ipd_mm", 67.05, 0.12));                                   // file 65.0
  r.Set(P("servo.Ry.centre_us", robot.servos[1].centre_us - 27.4, 0.3));  // 3 deg off
  r.Set(P("servo.Neck.deg_per_us", 0.1056, 2e-5));                        // -6.5 %
  r.Set(P("servo.Ly.deg_per_us", -0.121, 3e-5));                          // file direction wrong
  const auto d = CompareWithRobotFile(r, robot);
  ASSERT_EQ(d.size(), 4u);
  EXPECT_EQ(d[0].what, "IPD");
  EXPECT_NE(d[0].message.find("IPD 67.05 \u00b1 0.12 mm, robot file says 65 mm"), std::string::npos) << d[0].message;
  EXPECT_EQ(d[1].what, "Ry centre");
  EXPECT_EQ(d[2].what, "Ly direction");
  EXPECT_NE(d[2].message.find("direction: 1"), std::string::npos) << d[2].message;  // the file says -1
  EXPECT_EQ(d[3].what, "Neck scale");
  EXPECT_NE(d[3].message.find("-6.5 %"), std::string::npos) << d[3].message;

  const auto w = RobotFileWarnings(d);
  ASSERT_EQ(w.size(), 3u);  // IPD; centres; scales and directions
  EXPECT_NE(w[0].find("robot file disagrees with the fit (the IPD; update ipd_mm): IPD 67.05"), std::string::npos)
      << w[0];
  EXPECT_NE(w[2].find("Ly turns the other way"), std::string::npos) << w[2];
  EXPECT_NE(w[2].find("Neck 0.1056 \u00b1 2e-05 deg/\u00b5s, file 0.113 deg/\u00b5s (-6.5 %"), std::string::npos)
      << w[2];
}

TEST(RobotFileCheck, ALargeButUncertainDifferenceIsNotADisagreement) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  CalibrationResult r = AgreeingFit(robot);
  r.Set(P("head.ipd_mm", 66.0, 0.5));  // 1 mm off but only 2 sigma: the data cannot tell
  EXPECT_TRUE(CompareWithRobotFile(r, robot).empty());
}

TEST(RobotFileCheck, UndeterminedAndNonFiniteParametersSayNothing) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  CalibrationResult r = AgreeingFit(robot);
  Parameter held = P("servo.Neck.centre_us", 1400, NAN);
  held.determined = false;
  r.Set(held);
  r.Set(P("head.ipd_mm", NAN, 0.1));
  EXPECT_TRUE(CompareWithRobotFile(r, robot).empty());
}

TEST(RobotFileCheck, BadTolerancesAreRefused) {
  RobotFileTolerance t;
  t.centre_us = -1;
  std::string why;
  EXPECT_FALSE(t.Check(&why));
  EXPECT_FALSE(why.empty());
  t = {};
  t.n_sigma = NAN;
  EXPECT_FALSE(t.Check(&why));
}

}  // namespace
}  // namespace owlcal::fitting
