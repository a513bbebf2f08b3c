#include "fitting/loop_model.h"

#include <cmath>

#include <gtest/gtest.h>

#include "fitting/ploop_analysis.h"
#include "fitting/servo_motion_fit.h"

namespace owlcal::fitting {
namespace {

// An ideal servo (instant, no lag), a delay of exactly d frames and no dead zone: the loop model
// is the course's y(k+1) = y(k) + K (1 - y(k - d)).
TEST(LoopModel, IdealServoReducesToTheDelayedPLoop) {
  LoopModel m;
  m.slew_us_per_s = 1e9;
  m.lag_s = 0;
  m.noise_px = 0;
  m.tolerance_px = 1e-6;
  m.command_delay_s = 1e-6;
  m.exposure_delay_s = 3.0 / 30;  // the virtual Owl at 100 ms: a command sent at frame k shows from frame k + 4 on
  for (double gain : {0.05, 0.1, 0.2}) {
    const LoopTrial t = SimulateLoopStep(m, gain, 100, 60, 1);
    // A command sent when frame k arrives shows from frame k + 4 on: the course model's d = 3
    // (its update k + 1 uses y(k - d), the result of update k - d, decided at frame k - d - 1),
    // and the frame sees the command decided 3 updates earlier.
    const std::vector<double> ideal = SimulateDelayedPLoop(gain, 3, 60);
    for (int k = 3; k < 60; ++k) EXPECT_NEAR(t.y[k], ideal[k - 3], 0.011) << "gain " << gain << " frame " << k;
  }
}

TEST(LoopModel, PwmStepWidensTheDeadZoneAndTheBandSoTrialsSettle) {
  LoopModel m;
  m.resolution = models::ServoResolution::Rounding(5, 2);
  m.noise_px = 0.1;
  EXPECT_NEAR(m.DeadZonePx(), 0.6 * 5 * 1.15, 1e-9);
  const LoopTrial t = SimulateLoopStep(m, 0.1, 45, 90, 3);
  EXPECT_TRUE(t.info.settled);
  EXPECT_GT(t.band, 0.02);
  // Every command is on the 5 us grid.
  for (int c : t.command_us) EXPECT_EQ(c % 5, 0);
}

TEST(LoopModel, LatencyMakesLargeGainsOscillate) {
  LoopModel m;
  m.noise_px = 0;
  const LoopTrial slow = SimulateLoopStep(m, 0.1, 88, 90, 1);
  const LoopTrial fast = SimulateLoopStep(m, 0.6, 88, 90, 1);
  EXPECT_TRUE(slow.info.settled);
  EXPECT_LT(slow.info.overshoot_pct, 5);
  EXPECT_GT(fast.info.overshoot_pct, 30);
}

// The slew rate, lag and exposure delay of a servo come back from step trials of the loop model.
TEST(ServoMotionFit, RecoversSlewLagAndDelayFromLoopTrials) {
  LoopModel m;
  m.slew_us_per_s = 2700;
  m.lag_s = 0.04;
  m.exposure_delay_s = 0.118;
  m.hysteresis_us = 3;
  m.px_per_us = 1.2;
  m.noise_px = 0.08;
  std::vector<MotionSegment> segs;
  uint64_t seed = 1;
  for (double gain : {0.1, 0.3})
    for (double amp : {45.0, -90.0, 175.0}) {
      const LoopTrial t = SimulateLoopStep(m, gain, amp, 60, seed++);
      MotionSegment s;
      s.name = "gain " + std::to_string(gain);
      s.initial_approach = amp >= 0 ? 1 : -1;
      for (size_t k = 0; k < t.t_s.size(); ++k) s.frames.push_back({t.t_s[k], t.offset_px[k], true, t.command_us[k]});
      segs.push_back(s);
    }
  ServoMotionFitOptions o;
  o.exposure_delay_min_s = 0.1;
  o.exposure_delay_max_s = 0.1333;
  o.hysteresis_us = 3;
  const ServoMotionFit f = FitServoMotion(segs, o);
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_NEAR(f.lag_s, 0.04, 0.006) << f.message;
  EXPECT_NEAR(f.exposure_delay_s, 0.118, 0.006) << f.message;
  EXPECT_NEAR(f.px_per_us, -1.2, 0.02) << f.message;
  if (f.slew_determined) {
    EXPECT_NEAR(f.slew_us_per_s, 2700, 3 * f.slew_sigma_us_per_s + 100) << f.message;
  }
  EXPECT_LT(f.rms_px, 0.12);
}

// A servo whose slew never limits (15 fps, 200 ms delay, 100 ms lag): the steps do not determine
// the slew. Without a prior it is named as not determined; with one it is held at the prior, named
// as such, and the lag and the delay are fitted again with it.
TEST(ServoMotionFit, AnUndeterminedSlewIsHeldAtThePriorAndNamed) {
  LoopModel m;
  m.fps = 15;
  m.slew_us_per_s = 1e6;
  m.lag_s = 0.1;
  m.exposure_delay_s = 0.2;
  m.px_per_us = 1.2;
  m.noise_px = 0.08;
  std::vector<MotionSegment> segs;
  uint64_t seed = 1;
  for (double gain : {0.1, 0.2})
    for (double amp : {45.0, -90.0}) {
      const LoopTrial t = SimulateLoopStep(m, gain, amp, 60, seed++);
      MotionSegment s;
      s.initial_approach = amp >= 0 ? 1 : -1;
      for (size_t k = 0; k < t.t_s.size(); ++k) s.frames.push_back({t.t_s[k], t.offset_px[k], true, t.command_us[k]});
      segs.push_back(s);
    }
  ServoMotionFitOptions o;
  o.fps = 15;
  o.exposure_delay_min_s = 0.15;
  o.exposure_delay_max_s = 0.3;
  const ServoMotionFit free = FitServoMotion(segs, o);
  ASSERT_TRUE(free.ok) << free.message;
  EXPECT_FALSE(free.slew_determined) << free.message;
  EXPECT_FALSE(free.slew_from_prior);
  o.prior_slew_us_per_s = 2655;
  const ServoMotionFit f = FitServoMotion(segs, o);
  ASSERT_TRUE(f.ok) << f.message;
  EXPECT_TRUE(f.slew_from_prior) << f.message;
  EXPECT_FALSE(f.slew_determined);
  EXPECT_NEAR(f.slew_us_per_s, 2655, 1e-6);
  EXPECT_NE(f.message.find("slew 2655 us/s (prior: not determined)"), std::string::npos) << f.message;
  EXPECT_TRUE(f.lag_determined) << f.message;
  EXPECT_FALSE(f.lag_from_prior);
  EXPECT_NEAR(f.lag_s, 0.1, 0.01) << f.message;
  EXPECT_NEAR(f.exposure_delay_s, 0.2, 0.01) << f.message;
  ServoMotionFitOptions bad;
  bad.prior_slew_us_per_s = -1;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("prior_slew_us_per_s"), std::string::npos) << why;
}

TEST(ServoMotionFit, RefusesSegmentsWithoutMotion) {
  MotionSegment s;
  for (int k = 0; k < 20; ++k) s.frames.push_back({k / 30.0, 0.1 * k, true, 1500});
  const ServoMotionFit f = FitServoMotion({s}, {});
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.message.find("too few"), std::string::npos) << f.message;
}

}  // namespace
}  // namespace owlcal::fitting
