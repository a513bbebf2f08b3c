#include "fitting/step_response.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace step_response_test {

StepInfoOptions InitFinal(double y_init, double y_final) {
  StepInfoOptions o;
  o.y_init = y_init;
  o.y_final = y_final;
  return o;
}

// Unit step response of (1 - s) / (s^2 + s + 1), by partial fractions:
// Y(s) = 1/s - (s + 2) / (s^2 + s + 1)  ->  y(t) = 1 - e^{-t/2} (cos wt + (3/2)/w sin wt),
// w = sqrt(3)/2.
double NonMinimumPhaseStep(double t) {
  const double w = std::sqrt(3.0) / 2.0;
  return 1.0 - std::exp(-t / 2) * (std::cos(w * t) + 1.5 / w * std::sin(w * t));
}

TEST(StepInfo, ReproducesStepinfoOfNonMinimumPhaseSystem) {
  std::vector<double> t, y;
  for (int k = 0; k <= 300000; ++k) {
    t.push_back(k * 1e-4);
    y.push_back(NonMinimumPhaseStep(t.back()));
  }
  StepInfoOptions o;
  o.y_init = 0.0;
  o.y_final = 1.0;
  const StepInfo s = ComputeStepInfo(t, y, o);
  EXPECT_NEAR(s.rise_time, 1.266, 1e-3);
  EXPECT_TRUE(s.settled);
  EXPECT_NEAR(s.settling_time, 8.993, 1e-3);
  EXPECT_NEAR(s.overshoot_pct, 20.87, 1e-2);
  EXPECT_NEAR(s.undershoot_pct, 28.02, 1e-2);
  EXPECT_NEAR(s.peak, 1.2087, 1e-3);
  EXPECT_NEAR(s.peak_time, 4.232, 1e-3);
  EXPECT_NEAR(s.steady_state_error, 0.0, 1e-12);
}

TEST(StepInfo, MatchesClosedFormOfSecondOrderSystems) {
  for (double zeta : {0.2, 0.4, 0.7}) {
    const double wn = 3.0;
    std::vector<double> t, y;
    for (int k = 0; k <= 200000; ++k) {
      t.push_back(k * 1e-4);
      y.push_back(SecondOrderStep(zeta, wn, t.back()));
    }
    StepInfoOptions o;
    o.y_init = 0.0;
    o.y_final = 1.0;
    const StepInfo s = ComputeStepInfo(t, y, o);
    EXPECT_NEAR(s.overshoot_pct, SecondOrderOvershootPct(zeta), 1e-3) << "zeta " << zeta;
    EXPECT_NEAR(s.peak_time, SecondOrderPeakTime(zeta, wn), 2e-4) << "zeta " << zeta;
    EXPECT_EQ(s.undershoot_pct, 0.0);
    // Settling from the envelope: |y - 1| <= e^{-zeta wn t} / sqrt(1 - zeta^2) <= 0.02 bounds it.
    const double envelope_ts = -std::log(0.02 * std::sqrt(1 - zeta * zeta)) / (zeta * wn);
    EXPECT_LE(s.settling_time, envelope_ts + 1e-4) << "zeta " << zeta;
    EXPECT_GT(s.settling_time, 0.5 * envelope_ts) << "zeta " << zeta;
  }
  // Critically damped, wn = 1: 10 % at t = 0.5318, 90 % at t = 3.8897 (roots of
  // 1 - e^-t (1 + t) = level), no overshoot.
  std::vector<double> t, y;
  for (int k = 0; k <= 200000; ++k) {
    t.push_back(k * 1e-4);
    y.push_back(SecondOrderStep(1.0, 1.0, t.back()));
  }
  const StepInfo s = ComputeStepInfo(t, y, InitFinal(0.0, 1.0));
  EXPECT_NEAR(s.rise_time, 3.8897 - 0.5318, 1e-3);
  EXPECT_EQ(s.overshoot_pct, 0.0);
  // 2 %: 1 - e^-t (1 + t) = 0.98 at t = 5.8335.
  EXPECT_NEAR(s.settling_time, 5.8335, 1e-3);
}

TEST(StepInfo, UsesExplicitInitialValueAndReference) {
  // A downward step from 10 to 4 with a 5 % overshoot below 4 and a reference of 3.9.
  std::vector<double> t = {0, 1, 2, 3, 4, 5, 6};
  std::vector<double> y = {10, 10, 6, 3.7, 4.1, 4.0, 4.0};
  StepInfoOptions o;
  o.y_init = 10.0;
  o.reference = 3.9;
  const StepInfo s = ComputeStepInfo(t, y, o);
  EXPECT_DOUBLE_EQ(s.y_final, 4.0);
  EXPECT_NEAR(s.overshoot_pct, 5.0, 1e-9);
  EXPECT_DOUBLE_EQ(s.peak, 3.7);
  EXPECT_DOUBLE_EQ(s.peak_time, 3.0);
  EXPECT_EQ(s.settling_index, 4);  // |4.1 - 4| = 0.1 <= 0.12, |3.7 - 4| = 0.3 > 0.12
  EXPECT_NEAR(s.steady_state_error, -0.1, 1e-12);
}

TEST(StepInfo, ReportsUnsettledAndRejectsBadInput) {
  std::vector<double> t = {0, 1, 2, 3};
  std::vector<double> y = {0, 2, -1, 3};
  const StepInfo s = ComputeStepInfo(t, y, InitFinal(0.0, 1.0));
  EXPECT_FALSE(s.settled);
  EXPECT_TRUE(std::isnan(s.settling_time));
  EXPECT_THROW(ComputeStepInfo({0, 1}, {0, 1, 2}), std::invalid_argument);
  EXPECT_THROW(ComputeStepInfo({0, 0}, {0, 1}), std::invalid_argument);
  EXPECT_THROW(ComputeStepInfo({0, 1}, {1, 1}), std::invalid_argument);
  StepInfoOptions bad;
  bad.settling_band = 0;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("settling_band"), std::string::npos);
}

}  // namespace step_response_test
}  // namespace owlcal::fitting
