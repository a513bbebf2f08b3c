// The VOR's numbers on synthetic samples with known gain, lag and noise (fitting/vor_analysis.h).
#include "fitting/vor_analysis.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace vor_analysis_test {

// Neck A sin(wt), eye -g A sin(w(t - lag)) + offsets, drift and noise, at 30 fps.
struct Synthetic {
  std::vector<double> t, neck, pan;
};
Synthetic MakeSine(double hz, double gain, double lag_s, double noise_deg, int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, noise_deg);
  Synthetic s;
  for (int k = 0; k < int(2 / hz * 30); ++k) {
    const double t = k / 30.0 + 0.013;
    s.t.push_back(t);
    s.neck.push_back(3 + 10 * std::sin(2 * M_PI * hz * t) + n(rng));
    s.pan.push_back(-1 + 0.02 * t - gain * 10 * std::sin(2 * M_PI * hz * (t - lag_s)) + n(rng));
  }
  return s;
}

TEST(VorAnalysis, RecoversGainAndLagOfANoiselessSine) {
  const Synthetic s = MakeSine(0.5, 0.93, 0.040, 0, 1);
  const VorGain g = GainFromSines(FitSine(s.t, s.neck, 0.5), FitSine(s.t, s.pan, 0.5), 0.5);
  ASSERT_TRUE(g.ok) << g.reason;
  EXPECT_NEAR(g.gain, 0.93, 1e-9);
  EXPECT_NEAR(g.lag_ms, 40, 1e-6);
  EXPECT_NEAR(g.lag_deg, 0.040 * 0.5 * 360, 1e-6);
}

TEST(VorAnalysis, SigmasCoverTheScatterOfNoisyFits) {
  // 200 noisy repetitions: the reported sigma matches the scatter of the estimates within 25 %.
  double sum = 0, sum2 = 0, sigma = 0, lag_sum = 0, lag_sum2 = 0, lag_sigma = 0;
  const int n = 200;
  for (int i = 0; i < n; ++i) {
    const Synthetic s = MakeSine(1.0, 1.05, -0.010, 0.3, 100 + i);
    const VorGain g = GainFromSines(FitSine(s.t, s.neck, 1.0), FitSine(s.t, s.pan, 1.0), 1.0);
    ASSERT_TRUE(g.ok);
    sum += g.gain;
    sum2 += g.gain * g.gain;
    sigma += g.gain_sigma / n;
    lag_sum += g.lag_ms;
    lag_sum2 += g.lag_ms * g.lag_ms;
    lag_sigma += g.lag_sigma_ms / n;
  }
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  const double lag_mean = lag_sum / n, lag_sd = std::sqrt(lag_sum2 / n - lag_mean * lag_mean);
  EXPECT_NEAR(mean, 1.05, 3 * sd / std::sqrt(n));
  EXPECT_NEAR(sigma / sd, 1.0, 0.25) << "reported " << sigma << ", scatter " << sd;
  EXPECT_NEAR(lag_mean, -10, 3 * lag_sd / std::sqrt(n));
  EXPECT_NEAR(lag_sigma / lag_sd, 1.0, 0.25) << "reported " << lag_sigma << ", scatter " << lag_sd;
}

TEST(VorAnalysis, RefusesTooFewSamplesOrTooShortASpan) {
  EXPECT_FALSE(FitSine({0, 0.1, 0.2}, {0, 1, 2}, 1).ok);
  std::vector<double> t, y;
  for (int k = 0; k < 10; ++k) {
    t.push_back(k / 30.0);
    y.push_back(std::sin(2 * M_PI * 0.2 * t.back()));
  }
  const SineFit f = FitSine(t, y, 0.2);  // 0.3 s of a 5 s period
  EXPECT_FALSE(f.ok);
  EXPECT_NE(f.reason.find("half a period"), std::string::npos) << f.reason;
  const VorGain g = GainFromSines(f, FitSine(t, y, 0.2), 0.2);
  EXPECT_FALSE(g.ok);
  EXPECT_NE(g.reason.find("neck"), std::string::npos);
}

TEST(VorAnalysis, StepGainFromTheHoldAgainstTheRest) {
  std::vector<double> t, neck, pan;
  for (int k = 0; k < 75; ++k) {  // 0.5 s rest, 1 s at +8 deg (eye lagging), 1 s back
    const double tt = k / 30.0;
    t.push_back(tt);
    const bool on = tt >= 0.5 && tt < 1.5;
    neck.push_back(on ? 8 : 0);
    pan.push_back(on ? -0.97 * 8 * (1 - std::exp(-(tt - 0.5) / 0.05)) : 0.0);
  }
  const VorGain g = StepGain(t, neck, pan, 0.5, 1.0);
  ASSERT_TRUE(g.ok) << g.reason;
  EXPECT_NEAR(g.gain, 0.97, 1e-6);
  const VorGain none = StepGain(t, neck, pan, 0.5, 0.01);
  EXPECT_FALSE(none.ok);
}

TEST(VorAnalysis, SlipOfAKnownMotionSkipsMissingFrames) {
  // x moves 3 px per frame at 30 fps = 90 px/s; the angle 0.3 deg per frame = 9 deg/s; frame 5 is lost.
  std::vector<double> t, x, a;
  std::vector<bool> found;
  for (int k = 0; k < 10; ++k) {
    t.push_back(k / 30.0);
    x.push_back(100 + 3 * k);
    a.push_back(0.3 * k);
    found.push_back(k != 5);
  }
  const SlipStats s = ComputeSlip(t, x, a, found);
  EXPECT_EQ(s.num_samples, 9);
  EXPECT_EQ(s.num_velocities, 7);  // 0-1 .. 3-4, 6-7 .. 8-9
  EXPECT_NEAR(s.rms_px_per_s, 90, 1e-9);
  EXPECT_NEAR(s.peak_px_per_s, 90, 1e-9);
  EXPECT_NEAR(s.rms_deg_per_s, 9, 1e-9);
  EXPECT_NEAR(s.peak_px, 27, 1e-9);
}

}  // namespace vor_analysis_test
}  // namespace owlcal::fitting
