#include "sim/servo_dynamics.h"

#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>

#include "models/servo_resolution.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Independent reference: integrate r' = clamp((target - r) * inf, -S, S), T y' = r - y with
// a small explicit Euler step.
double EulerReference(double r, double y, double target, double slew, double lag, double t_end) {
  const double h = 1e-6;
  for (double t = 0; t < t_end - 1e-12; t += h) {
    const double step = std::min(h, t_end - t);
    const double dr = std::clamp(target - r, -slew * step, slew * step);
    r += dr;
    y += (r - y) * step / lag;
  }
  return y;
}

ServoTruth Servo() {
  ServoTruth s;
  s.direction = 1;
  s.centre_us = 1520;
  s.deg_per_us = 0.11;
  s.quad_deg = 0.5;
  s.cubic_deg = -1.0;
  s.hysteresis_us = 2;
  s.dead_band_us = 1;
  s.quantum_us = 1;
  s.slew_deg_per_s = 350;
  s.lag_s = 0.03;
  s.endstop_lo_us = 1150;
  s.endstop_hi_us = 1880;
  return s;
}

TEST(ServoDynamics, StepFollowsTheSlewLimitedLaggedTrajectory) {
  const ServoTruth truth = Servo();
  ServoDynamics servo(truth, 1520, 0);
  const auto p = truth.MapParams();
  const double a0 = models::ServoMap::JointAngle(p.data(), 1, 1520, 0);
  ASSERT_TRUE(servo.Command(1720, 1'000'000));  // +200 us at t = 1 ms
  const double a1 = models::ServoMap::JointAngle(p.data(), 1, 1720, +1);
  EXPECT_NEAR(servo.TargetRad(), a1, 1e-12);
  // Analytic: the reference ramps at S for |a1 - a0| / S, the joint lags it.
  const double slew = truth.slew_deg_per_s * kDeg, lag = truth.lag_s;
  const double t_ramp = (a1 - a0) / slew;
  std::printf("step %.2f deg, ramp %.1f ms\n", (a1 - a0) / kDeg, t_ramp * 1e3);
  double max_err = 0;
  for (double t : {0.0, 0.005, 0.02, t_ramp * 0.5, t_ramp, t_ramp + 0.01, 0.1, 0.2, 0.4}) {
    const double y = servo.AngleAt(1'000'000 + int64_t(t * 1e9));
    double expected;
    if (t <= t_ramp) {
      expected = a0 + slew * (t - lag) + slew * lag * std::exp(-t / lag);
    } else {
      const double y1 = a0 + slew * (t_ramp - lag) + slew * lag * std::exp(-t_ramp / lag);
      expected = a1 + (y1 - a1) * std::exp(-(t - t_ramp) / lag);
    }
    max_err = std::max(max_err, std::abs(y - expected));
    EXPECT_NEAR(y, expected, 1e-8) << "t=" << t;  // t is truncated to whole ns
    EXPECT_NEAR(y, EulerReference(a0, a0, a1, slew, lag, t), 2e-5) << "t=" << t;
  }
  // Velocity never exceeds the slew limit.
  double prev = servo.AngleAt(1'000'000);
  for (int i = 1; i < 400; ++i) {
    const double y = servo.AngleAt(1'000'000 + i * 1'000'000);
    EXPECT_LE((y - prev) / 1e-3, slew * (1 + 1e-9));
    prev = y;
  }
  EXPECT_NEAR(servo.AngleAt(2'000'000'000), a1, 1e-9);
}

TEST(ServoDynamics, CommandDuringMotionContinuesFromTheCurrentState) {
  const ServoTruth truth = Servo();
  ServoDynamics servo(truth, 1520, 0);
  servo.Command(1800, 0);
  const int64_t t_mid = 40'000'000;
  const double y_mid = servo.AngleAt(t_mid);
  const double r_mid = servo.ReferenceAt(t_mid);
  servo.Command(1500, t_mid);
  // Continuous at the switch and heading back.
  EXPECT_NEAR(servo.AngleAt(t_mid), y_mid, 1e-12);
  EXPECT_NEAR(servo.ReferenceAt(t_mid), r_mid, 1e-12);
  EXPECT_LT(servo.AngleAt(t_mid + 300'000'000), y_mid);
  // History before the second command is still exact.
  ServoDynamics fresh(truth, 1520, 0);
  fresh.Command(1800, 0);
  EXPECT_NEAR(servo.AngleAt(20'000'000), fresh.AngleAt(20'000'000), 1e-12);
}

TEST(ServoDynamics, EndStopsHoldTheJoint) {
  const ServoTruth truth = Servo();
  ServoDynamics servo(truth, 1520, 0);
  servo.Command(2000, 0);  // beyond the high stop at 1880
  EXPECT_NEAR(servo.AngleAt(3'000'000'000), truth.StopHiRad(), 1e-12);
  for (int64_t i = 0; i < 300; ++i) EXPECT_LE(servo.AngleAt(i * 10'000'000), truth.StopHiRad() + 1e-12);
  servo.Command(1000, 3'000'000'000);
  EXPECT_NEAR(servo.AngleAt(6'000'000'000), truth.StopLoRad(), 1e-12);
}

TEST(ServoDynamics, BacklashDeadBandAndQuantum) {
  ServoTruth truth = Servo();
  truth.lag_s = 0;
  ServoDynamics servo(truth, 1520, 0);
  const auto p = truth.MapParams();
  // Approached from below and from above, the same pulse gives angles 2 * hysteresis apart.
  servo.Command(1600, 0);
  const double up = servo.AngleAt(1'000'000'000);
  servo.Command(1700, 1'000'000'000);
  servo.Command(1600, 2'000'000'000);
  const double down = servo.AngleAt(3'000'000'000);
  EXPECT_NEAR(up - down,
              models::ServoMap::JointAngle(p.data(), 1, 1600, 1) - models::ServoMap::JointAngle(p.data(), 1, 1600, -1),
              1e-12);
  EXPECT_GT(down, up);  // backlash: the joint lags behind the direction it came from
  // Dead band of 3 us: a 2 us change is ignored.
  truth.dead_band_us = 3;
  ServoDynamics db(truth, 1520, 0);
  EXPECT_FALSE(db.Command(1522, 0));
  EXPECT_TRUE(db.Command(1523, 1));
  // Quantum 5 us: 1547 and 1548 land on 1545 and 1550.
  truth.dead_band_us = 0;
  truth.quantum_us = 5;
  ServoDynamics q(truth, 1520, 0);
  q.Command(1547, 0);
  EXPECT_EQ(q.ActivePulseUs(), 1545);
  q.Command(1548, 1);
  EXPECT_EQ(q.ActivePulseUs(), 1550);
}

// models::ServoResolution is the model owlcal's controllers and ranging use for what a servo
// applies; it must say exactly what the truth does, for every step and dead band.
TEST(ServoDynamics, AppliedPulseAndApproachFollowModelsServoResolution) {
  uint32_t x = 12345;
  auto next = [&x] {
    x = x * 1664525u + 1013904223u;
    return int(x >> 8);
  };
  for (int step : {1, 2, 5}) {
    for (int dead : {1, 2, 3, 5, 7}) {
      ServoTruth t = Servo();
      t.quantum_us = step;
      t.dead_band_us = dead;
      ServoDynamics d(t, 1520, 0);
      const models::ServoResolution r = models::ServoResolution::Rounding(step, dead);
      models::ServoState s{1520, 0};
      for (int k = 1; k < 400; ++k) {
        const int u = 1500 + next() % 41;
        d.Command(u, k * 1'000'000);
        s = r.Next(s, u);
        ASSERT_EQ(d.ActivePulseUs(), s.applied_us) << "step " << step << " dead band " << dead << " command " << k;
        if (s.approach != 0) {
          ASSERT_EQ(d.Approach(), s.approach);
        }
      }
    }
  }
}

TEST(VirtualOwlServos, CommandsBeyondLimitsAreClampedAndEndStopsRespected) {
  VirtualOwlOptions o;
  o.encode_jpeg = false;
  VirtualOwl owl(o);
  const models::RobotConfig& cfg = owl.Config();
  robot::PwmVector extreme{};
  for (int i = 0; i < models::kNumServos; ++i) extreme[i] = 9999;
  const robot::ServoReply r = owl.SendServos(extreme);
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.text, "ok");
  EXPECT_TRUE(r.clamped);
  for (int i = 0; i < models::kNumServos; ++i) EXPECT_EQ(r.sent[i], cfg.servos[i].max_us);
  owl.SleepNs(3'000'000'000);
  const auto a = owl.ServoAnglesAt(owl.NowNs());
  for (int i = 0; i < models::kNumServos; ++i) {
    const ServoTruth& s = owl.Truth().servos[i];
    EXPECT_GE(a[i], s.StopLoRad() - 1e-12);
    EXPECT_LE(a[i], s.StopHiRad() + 1e-12);
    // Ry's and the truth's stops inside the configured max: the joint sits on the stop.
    const double cmd = models::ServoMap::JointAngle(s.MapParams().data(), s.direction, cfg.servos[i].max_us, 1);
    EXPECT_NEAR(a[i], std::clamp(cmd, s.StopLoRad(), s.StopHiRad()), 1e-9) << models::kServoNames[i];
  }
}

}  // namespace
}  // namespace owlcal::sim
