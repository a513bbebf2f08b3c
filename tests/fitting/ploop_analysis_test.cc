#include "fitting/ploop_analysis.h"

#include <cmath>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace {

StepInfoOptions InitFinal(double y_init, double y_final) {
  StepInfoOptions o;
  o.y_init = y_init;
  o.y_final = y_final;
  return o;
}

StepInfo FrameStepInfo(const std::vector<double>& y) {
  std::vector<double> t(y.size());
  for (size_t k = 0; k < t.size(); ++k) t[k] = double(k);
  return ComputeStepInfo(t, y, InitFinal(0.0, 1.0));
}

TEST(DelayedPLoop, SettlesAtFrame22WithoutOvershootForGainPoint1) {
  const std::vector<double> y = SimulateDelayedPLoop(0.1, 3, 200);
  EXPECT_DOUBLE_EQ(y[0], 0.0);
  EXPECT_DOUBLE_EQ(y[1], 0.1);  // y(1) = y(0) + K (1 - y(-3))
  const StepInfo s = FrameStepInfo(y);
  EXPECT_EQ(s.settling_index, 22);
  EXPECT_LT(s.overshoot_pct, 1e-9);
}

TEST(DelayedPLoop, SettlesAtFrame49With56PercentOvershootForGainPoint3) {
  const StepInfo s = FrameStepInfo(SimulateDelayedPLoop(0.3, 3, 400));
  EXPECT_EQ(s.settling_index, 49);
  EXPECT_NEAR(s.overshoot_pct, 56.0, 0.01);
}

// docs/conventions.md, Facts "Control with latency" table, row by row.
TEST(DelayedPLoop, ReproducesTheControlTable) {
  struct Row {
    int d;
    double kcrit, kmono;
    int best_frames;
    double best_gain;
    int k01_frames;
    double k01_overshoot_pct;
  };
  const Row rows[] = {{3, 0.445, 0.105, 11, 0.131, 22, 0.0},
                      {4, 0.347, 0.082, 14, 0.102, 15, 1.3},
                      {5, 0.285, 0.067, 17, 0.084, 28, 7.6}};
  for (const Row& r : rows) {
    EXPECT_NEAR(CriticalGain(r.d), r.kcrit, 5e-4) << "d " << r.d;
    EXPECT_NEAR(MonotoneGain(r.d), r.kmono, 5e-4) << "d " << r.d;
    const auto sweep = SettlingVersusGain(GainGrid(0.001, 0.6, 0.001), r.d);
    const auto best = FastestStableGain(sweep);
    ASSERT_TRUE(best) << "d " << r.d;
    EXPECT_EQ(best->settling_frames, r.best_frames) << "d " << r.d;
    EXPECT_NEAR(best->gain, r.best_gain, 1e-9) << "d " << r.d;
    const auto k01 = SettlingVersusGain({0.1}, r.d);
    EXPECT_EQ(k01[0].settling_frames, r.k01_frames) << "d " << r.d;
    EXPECT_NEAR(k01[0].overshoot_pct, r.k01_overshoot_pct, 0.05) << "d " << r.d;
    // Above K_crit nothing settles; just below it the loop is still stable.
    const auto around = SettlingVersusGain({CriticalGain(r.d) * 0.97, CriticalGain(r.d) * 1.03}, r.d, 30.0, 20000);
    EXPECT_TRUE(around[0].settled) << "d " << r.d;
    EXPECT_FALSE(around[1].settled) << "d " << r.d;
    // No overshoot up to K_mono, overshoot just above it.
    EXPECT_LT(SettlingVersusGain({MonotoneGain(r.d) * 0.999}, r.d)[0].overshoot_pct, 1e-9);
    EXPECT_GT(SettlingVersusGain({MonotoneGain(r.d) * 1.05}, r.d)[0].overshoot_pct, 1e-6);
  }
}

TEST(DelayedPLoop, PhysicalLowerBoundMatchesFacts) {
  // 5 deg at 400 deg/s + 100 ms + one frame at 30 fps = 146 ms; 300 deg/s + 150 ms = 200 ms.
  EXPECT_NEAR(PhysicalLowerBoundS(5, 400, 0.100), 0.146, 1e-3);
  EXPECT_NEAR(PhysicalLowerBoundS(5, 300, 0.150), 0.200, 1e-3);
  EXPECT_NEAR(PhysicalLowerBoundS(10, 400, 0.100), 0.158, 1e-3);
  EXPECT_NEAR(PhysicalLowerBoundS(10, 300, 0.150), 0.217, 1e-3);
  EXPECT_NEAR(PhysicalLowerBoundS(20, 400, 0.100), 0.183, 1e-3);
  EXPECT_NEAR(PhysicalLowerBoundS(20, 300, 0.150), 0.250, 1e-3);
}

}  // namespace
}  // namespace owlcal::fitting
