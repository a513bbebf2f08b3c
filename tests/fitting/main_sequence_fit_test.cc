// The main-sequence fit on synthetic frame-sampled saccades: the servo law with a known slew, lag
// and delay, sampled at 30 fps with the commands at golden-ratio phases of the frame clock, plus
// angle noise. The pooled fit and the main-sequence curve recover the slew and lag; a saccade
// without motion or frames is a row with its reason.
#include "fitting/main_sequence_fit.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

std::vector<SaccadeTrace> Synthetic(double slew, double lag, double delay, double noise_deg, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise_deg);
  std::vector<SaccadeTrace> out;
  int id = 0;
  for (double a : {2.0, 5.0, 10.0, 20.0, 30.0, 40.0})
    for (int rep = 0; rep < 4; ++rep, ++id) {
      SaccadeTrace t;
      t.id = id;
      const double dir = rep % 2 ? -1 : 1;
      const double phase = std::fmod((id + 1) * 0.6180339887498949, 1.0) / 30;
      const double start = -dir * a / 2;
      for (int k = 0; k < 18; ++k) {
        const double ts = (k + 1) / 30.0 - phase;  // arrival of the k-th frame after the command
        t.t_s.push_back(ts);
        t.angle_deg.push_back(start + SaccadeAngleDeg(ts - delay, dir * a, slew, lag) + n(rng));
      }
      out.push_back(t);
    }
  return out;
}

TEST(MainSequenceFit, RecoversSlewAndLagFromThirtyFpsFrames) {
  const MainSequenceFit f = FitMainSequence(Synthetic(380, 0.025, 0.115, 0.01, 1), {});
  ASSERT_TRUE(f.motion.ok) << f.motion.message;
  std::cout << f.motion.message << "\n" << f.peak.message << "\n" << f.duration.message << "\n";
  EXPECT_NEAR(f.motion.slew_deg_per_s, 380, 3 * f.motion.slew_sigma_deg_per_s + 1);
  EXPECT_LT(f.motion.slew_sigma_deg_per_s, 10);
  EXPECT_NEAR(f.motion.lag_s, 0.025, 3 * f.motion.lag_sigma_s + 1e-4);
  EXPECT_NEAR(f.motion.delay_s, 0.115, 3 * f.motion.delay_sigma_s + 1e-4);
  ASSERT_TRUE(f.peak.ok) << f.peak.message;
  EXPECT_NEAR(f.peak.vmax_deg_per_s, 380, 0.02 * 380);
  EXPECT_NEAR(f.peak.lag_s, 0.025, 0.002);
  ASSERT_TRUE(f.duration.ok) << f.duration.message;
  EXPECT_NEAR(f.duration.slew_deg_per_s, 380, 0.02 * 380);
  for (const SaccadeMeasurement& m : f.saccades) {
    ASSERT_TRUE(m.ok) << m.reason;
    EXPECT_NEAR(m.peak_deg_per_s, PeakVelocityDegPerS(m.amplitude_deg, 380, 0.025), 0.02 * 380);
  }
}

TEST(MainSequenceFit, SlowServoWithLongLag) {
  const MainSequenceFit f = FitMainSequence(Synthetic(300, 0.045, 0.15, 0.02, 2), {});
  ASSERT_TRUE(f.motion.ok) << f.motion.message;
  EXPECT_NEAR(f.motion.slew_deg_per_s, 300, 0.02 * 300);
  EXPECT_NEAR(f.peak.vmax_deg_per_s, 300, 0.03 * 300);
  EXPECT_NEAR(f.peak.lag_s, 0.045, 0.004);
}

TEST(MainSequenceFit, SaccadesWithoutMotionOrFramesAreRowsWithAReason) {
  std::vector<SaccadeTrace> t = Synthetic(380, 0.025, 0.115, 0.01, 3);
  for (double& a : t[0].angle_deg) a = 1.0;                                    // no motion
  for (size_t k = 2; k < t[1].angle_deg.size(); ++k) t[1].angle_deg[k] = NAN;  // lost
  const MainSequenceFit f = FitMainSequence(t, {});
  ASSERT_EQ(f.saccades.size(), t.size());
  EXPECT_FALSE(f.saccades[0].ok);
  EXPECT_NE(f.saccades[0].reason.find("no motion"), std::string::npos) << f.saccades[0].reason;
  EXPECT_FALSE(f.saccades[1].ok);
  EXPECT_NE(f.saccades[1].reason.find("too few"), std::string::npos) << f.saccades[1].reason;
  EXPECT_TRUE(f.motion.ok);
  EXPECT_EQ(f.motion.num_saccades, int(t.size()) - 2);
}

TEST(MainSequenceFit, DurationLaw) {
  // Above the threshold the duration grows as a / slew plus lag ln(V(a)): 40 - 20 deg takes
  // 20 / slew + lag ln(V(40) / V(20)) longer (52.6 + 2.9 ms).
  const double ratio = (1 - std::exp(-40 / 9.5)) / (1 - std::exp(-20 / 9.5));
  EXPECT_NEAR(
      DurationS(40, 380, 0.025, 30) - DurationS(20, 380, 0.025, 30), 20.0 / 380 + 0.025 * std::log(ratio), 1e-9);
  EXPECT_TRUE(std::isnan(DurationS(0.5, 380, 0.025, 30)));  // peak 19.6 deg/s: below 30
  EXPECT_NEAR(PeakVelocityDegPerS(40, 380, 0.025), 380 * (1 - std::exp(-40 / 9.5)), 1e-9);
}

}  // namespace
}  // namespace owlcal::fitting
