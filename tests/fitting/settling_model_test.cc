#include "fitting/settling_model.h"

#include <cmath>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

// "Measured" trials from a robot that is the loop model itself (other noise seeds).
std::vector<StepTrace> Trials(const LoopModel& robot, double deg_per_us) {
  std::vector<StepTrace> out;
  uint64_t seed = 1000;
  for (double gain : {0.1, 0.3})
    for (double amp : {5.0, 10.0, 20.0})
      for (int trial = 0; trial < 2; ++trial) {
        const LoopTrial t = SimulateLoopStep(robot, gain, amp / deg_per_us * (trial ? -1 : 1), 75, seed++);
        StepTrace s;
        s.gain = gain;
        s.amplitude_deg = amp;
        s.trial = trial;
        s.t_s = t.t_s;
        s.y = t.y;
        s.info = t.info;
        s.band = t.band;
        out.push_back(s);
      }
  return out;
}

TEST(SettlingModel, AModelOfTheRobotAgreesWithItsTrials) {
  LoopModel m;
  m.exposure_delay_s = 0.1;
  m.lag_s = 0.03;
  m.slew_us_per_s = 3300;
  const std::vector<StepTrace> trials = Trials(m, 0.113);
  ServoMotionFit motion;
  motion.exposure_delay_sigma_s = 0.001;
  const SettlingStudy st = CompareSettling(m, motion, trials, 3, 133, 0.113);
  ASSERT_EQ(st.rows.size(), 6u);
  for (const SettlingRow& r : st.rows) {
    EXPECT_EQ(r.num_trials, 2);
    EXPECT_EQ(r.num_ok, 2);
    EXPECT_TRUE(r.agreement.rfind("agrees", 0) == 0)
        << r.gain << " " << r.amplitude_deg << ": " << r.agreement << " " << r.why;
    EXPECT_FALSE(r.why.empty());
    EXPECT_TRUE(r.ideal_stable);  // K_crit(3) = 0.445
  }
  EXPECT_FALSE(st.curve.empty());
  EXPECT_EQ(st.notes.size(), 2u);
}

TEST(SettlingModel, ASlowerRobotIsFlaggedAndTheCourseModelsInstabilityExplained) {
  LoopModel robot;
  robot.exposure_delay_s = 0.1;
  robot.lag_s = 0.12;  // much more lag than the model has
  const std::vector<StepTrace> trials = Trials(robot, 0.113);
  LoopModel model = robot;
  model.lag_s = 0.02;
  const SettlingStudy st = CompareSettling(model, ServoMotionFit{}, trials, 5, 200, 0.113);
  int slower = 0;
  for (const SettlingRow& r : st.rows) {
    slower += r.agreement == "measured slower";
    if (r.gain == 0.3) {
      EXPECT_FALSE(r.ideal_stable);  // K_crit(5) = 0.285
      EXPECT_NE(r.why.find("unstable"), std::string::npos) << r.why;
    }
  }
  EXPECT_GE(slower, 2);
}

TEST(SettlingModel, FailedTrialsAreCountedNotTimed) {
  LoopModel m;
  std::vector<StepTrace> trials = Trials(m, 0.113);
  trials[0].status = calib::TrialStatus::kLostTarget;
  trials[1].status = calib::TrialStatus::kSkipped;
  const SettlingStudy st = CompareSettling(m, ServoMotionFit{}, trials, 3, 133, 0.113);
  const SettlingRow& r = st.rows.front();
  EXPECT_EQ(r.num_trials, 2);
  EXPECT_EQ(r.num_ok, 0);
  EXPECT_EQ(r.agreement, "no measurement");
  EXPECT_NE(r.why.find("2 of 2 trials did not run"), std::string::npos) << r.why;
}

// Regression: the loop model with an ideal servo settled SLOWER (2.3 s) than with the fitted slew
// and lag (0.8 s) at K = 0.1. A single noisy run was set against a median; over the same runs the
// ideal servo is still a little slower, and that is real: below the no-overshoot gain the lag
// acts as extra delay and the approach is faster. The "why" text says so.
TEST(SettlingModel, AnIdealServoSettlesLaterAtLowGainAndTheWhySaysWhy) {
  LoopModel m;
  m.exposure_delay_s = 0.1;
  m.hysteresis_us = 2;
  const std::vector<StepTrace> trials = Trials(m, 0.113);
  ServoMotionFit motion;
  motion.exposure_delay_sigma_s = 0.001;
  const SettlingStudy st = CompareSettling(m, motion, trials, 3, 133, 0.113);
  int checked = 0;
  for (const SettlingRow& r : st.rows) {
    if (r.gain != 0.1) continue;
    ++checked;
    ASSERT_TRUE(std::isfinite(r.no_servo_dynamics_s) && std::isfinite(r.predicted_median_s));
    // Slower, but by a few frames, not by a factor of three.
    EXPECT_GT(r.no_servo_dynamics_s, r.predicted_median_s) << r.amplitude_deg;
    EXPECT_LT(r.no_servo_dynamics_s, r.predicted_median_s + 0.3) << r.amplitude_deg;
    EXPECT_NE(r.why.find("that is real"), std::string::npos) << r.why;
  }
  EXPECT_EQ(checked, 3);
}

}  // namespace
}  // namespace owlcal::fitting
