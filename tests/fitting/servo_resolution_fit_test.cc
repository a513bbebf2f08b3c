#include "fitting/servo_resolution_fit.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

// A fine sweep of a servo with resolution `truth`, backlash `hyst_us`, `px_per_us` image motion
// and Gaussian position noise.
std::vector<ResolutionSample> Sweep(const models::ServoResolution& truth,
                                    double hyst_us,
                                    double px_per_us,
                                    double noise_px,
                                    int start_us,
                                    uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise_px);
  std::vector<ResolutionSample> out;
  models::ServoState s{truth.Stepped(start_us - 10), 1};
  s = truth.Next(s, start_us);
  for (int off : models::ResolutionSweepOffsets(20)) {
    s = truth.Next(s, start_us + off);
    out.push_back({start_us + off, 37.0 + px_per_us * (s.applied_us - hyst_us * s.approach) + n(rng)});
  }
  return out;
}

TEST(ServoResolutionFit, RecoversStepAndDeadBandOfManyServos) {
  int k = 0;
  for (int step : {1, 2, 5}) {
    for (int dead : {1, 2, 3, 5, 7}) {
      for (int phase_kind : {0, 1}) {
        const models::ServoResolution truth =
            phase_kind == 0 ? models::ServoResolution::Rounding(step, dead) : models::ServoResolution{step, dead, 0};
        for (double px : {1.25, -1.1}) {
          const auto samples = Sweep(truth, 2.5, px, 0.06, 1531 + k % 7, 100 + k);
          ++k;
          const ResolutionFit f = FitServoResolution(samples);
          ASSERT_TRUE(f.ok) << f.message;
          EXPECT_TRUE(f.determined) << f.message;
          EXPECT_EQ(f.resolution.step_us, step) << f.message;
          if (step > 1) {
            EXPECT_EQ(f.resolution.phase_us, truth.phase_us) << f.message;
          }
          // The dead band within the step: the range of dead bands that ignore the same moves.
          EXPECT_LE(f.dead_band_min_us, dead) << f.message;
          EXPECT_GE(f.dead_band_max_us, dead) << f.message;
          EXPECT_EQ(f.dead_band_max_us - f.dead_band_min_us, step == 1 ? 0 : step - 1) << f.message;
          EXPECT_EQ(f.resolution.MinMoveUs(), truth.MinMoveUs()) << f.message;
          EXPECT_NEAR(f.px_per_us, px, 0.02);
          EXPECT_NEAR(f.hysteresis_us, 2.5, 0.3) << f.message;
          // The replayed applied pulses are the truth's (up to a constant).
          models::ServoState t{truth.Stepped(samples.front().command_us - 10), 1};
          std::vector<int> applied;
          for (const auto& x : samples) applied.push_back((t = truth.Next(t, x.command_us)).applied_us);
          for (size_t i = 0; i < samples.size(); ++i)
            EXPECT_EQ(f.applied_us[i] - f.applied_us[0], applied[i] - applied[0]);
        }
      }
    }
  }
}

TEST(ServoResolutionFit, AppliedPulsesAreThoseOfTheTruthUpToTheDeadBandAmbiguity) {
  const models::ServoResolution truth{1, 3, 0};
  const auto samples = Sweep(truth, 1.0, 1.2, 0.05, 1540, 7);
  const ResolutionFit f = FitServoResolution(samples);
  ASSERT_TRUE(f.determined) << f.message;
  models::ServoState s{1530, 1};
  s = truth.Next(s, 1540);
  for (size_t i = 0; i < samples.size(); ++i) {
    s = truth.Next(s, samples[i].command_us);
    EXPECT_EQ(f.applied_us[i], s.applied_us) << i;
  }
}

TEST(ServoResolutionFit, NoMotionIsNotAResolution) {
  std::vector<ResolutionSample> still;
  for (int off : models::ResolutionSweepOffsets(20)) still.push_back({1500 + off, 12.0 + 0.05 * std::sin(off)});
  const ResolutionFit f = FitServoResolution(still);
  EXPECT_FALSE(f.determined);
  EXPECT_NE(f.message.find("too little motion"), std::string::npos) << f.message;
}

TEST(ServoResolutionFit, TooFewSamplesAreRefused) {
  const ResolutionFit f = FitServoResolution({{1500, 0.0}, {1501, 1.0}});
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.message.find("need 8"), std::string::npos);
}

TEST(ServoResolutionFit, NoisyPositionsAreNotClaimedDetermined) {
  const auto samples = Sweep(models::ServoResolution{1, 2, 0}, 1.0, 1.2, 1.5, 1540, 3);
  const ResolutionFit f = FitServoResolution(samples);
  EXPECT_FALSE(f.determined) << f.message;
}

}  // namespace
}  // namespace owlcal::fitting
