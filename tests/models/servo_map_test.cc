#include "models/servo_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <ceres/autodiff_cost_function.h>

#include "models/head_model.h"
#include "models/robot_config.h"
#include "tests/models/model_test_util.h"

namespace owlcal::models {
namespace {

constexpr double kDeg = M_PI / 180.0;

// Random maps that are monotone over 1000-2000 us by construction: the slope is at least
// 0.09 - (2*3*1.5 + 3*3*1.5^2) / 400 = 0.017 deg/us at |u - centre| <= 600 us.
std::array<double, ServoMap::kNumParams> RandomMap(std::mt19937& rng) {
  std::uniform_real_distribution<double> centre(1450, 1600), scale(0.09, 0.13), nl(-3, 3), hyst(0, 5);
  return {centre(rng), scale(rng), nl(rng), nl(rng), hyst(rng)};
}

TEST(ServoMap, InverseOfForwardIsIdentityOverTheRange) {
  std::mt19937 rng(21);
  double worst = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const auto p = RandomMap(rng);
    for (int direction : {+1, -1}) {
      ASSERT_TRUE(ServoMap::IsMonotone(p.data(), direction, 1000, 2000));
      for (int approach : {-1, 0, 1}) {
        for (double u = 1000; u <= 2000; u += 7.3) {
          const double angle = ServoMap::JointAngle(p.data(), direction, u, approach);
          const double back = ServoMap::PulseWidth(p.data(), direction, angle, approach);
          ASSERT_TRUE(std::isfinite(back)) << "trial " << trial << " u " << u;
          worst = std::max(worst, std::abs(back - u));
        }
      }
    }
  }
  EXPECT_LT(worst, 1e-9);
}

TEST(ServoMap, NominalLinearMapAtTheCentre) {
  const double p[5] = {1545, 0.113, 0, 0, 0};
  EXPECT_EQ(ServoMap::JointAngle(p, 1, 1545.0, 0), 0.0);
  EXPECT_NEAR(ServoMap::JointAngle(p, 1, 1645.0, 0), 11.3 * kDeg, 1e-12);
  EXPECT_NEAR(ServoMap::PulseWidth(p, 1, -11.3 * kDeg, 0), 1445.0, 1e-9);
}

TEST(ServoMap, MonotoneMapsPassAndFoldedOnesFail) {
  const double good[5] = {1545, 0.113, 2, -3, 1};
  EXPECT_TRUE(ServoMap::IsMonotone(good, 1, 1000, 2000));
  EXPECT_TRUE(ServoMap::IsMonotone(good, -1, 1000, 2000));
  const double folded[5] = {1545, 0.113, 0, -40, 0};  // the cubic bends the map back
  EXPECT_FALSE(ServoMap::IsMonotone(folded, 1, 1000, 2000));
  EXPECT_TRUE(ServoMap::IsMonotone(folded, 1, 1500, 1590));  // still fine near the centre
  const double flat[5] = {1545, 0.0, 0, 0, 0};
  EXPECT_FALSE(ServoMap::IsMonotone(flat, 1, 1000, 2000));
  EXPECT_TRUE(std::isnan(ServoMap::PulseWidth(flat, 1, 0.1, 0)));
}

TEST(ServoMap, DirectionIsHonoured) {
  std::mt19937 rng(22);
  for (int trial = 0; trial < 50; ++trial) {
    const auto p = RandomMap(rng);
    double last_up = -1e9, last_down = 1e9;
    for (double u = 1000; u <= 2000; u += 25) {
      const double up = ServoMap::JointAngle(p.data(), +1, u, 0);
      const double down = ServoMap::JointAngle(p.data(), -1, u, 0);
      EXPECT_EQ(down, -up);
      EXPECT_GT(up, last_up);      // direction +1: increasing PWM increases the angle
      EXPECT_LT(down, last_down);  // direction -1: it decreases
      EXPECT_GT(ServoMap::Slope(p.data(), +1, u, 0), 0);
      EXPECT_LT(ServoMap::Slope(p.data(), -1, u, 0), 0);
      last_up = up;
      last_down = down;
    }
  }
}

TEST(ServoMap, RobotDirectionsFollowTheGuide) {
  // Increasing PWM: Rx, Lx to the robot's right (+pan), Ry up (+tilt), Ly down (mirrored),
  // neck to the left (docs/conventions.md, Facts).
  const HeadModel head = NominalHeadModel(DefaultRobotConfig());
  const PwmVector c = DefaultRobotConfig().Centre();
  auto angles_with = [&](ServoIndex s, int delta) {
    PwmVector p = c;
    p[s] += delta;
    return head.Angles(p);
  };
  EXPECT_GT(angles_with(kRx, 50).pan_rad[kRightEye], 0);
  EXPECT_GT(angles_with(kLx, 50).pan_rad[kLeftEye], 0);
  EXPECT_GT(angles_with(kRy, 50).tilt_rad[kRightEye], 0);
  EXPECT_LT(angles_with(kLy, 50).tilt_rad[kLeftEye], 0);
  EXPECT_LT(angles_with(kNeck, 50).neck_rad, 0);
  const JointAngles centre = head.Angles(c);
  for (int e = 0; e < 2; ++e) {
    EXPECT_EQ(centre.pan_rad[e], 0);
    EXPECT_EQ(centre.tilt_rad[e], 0);
  }
  EXPECT_EQ(centre.neck_rad, 0);
}

TEST(ServoMap, HysteresisLagsBehindTheMove) {
  const double h = 4.0;
  const double p[5] = {1545, 0.113, 1.5, -1, h};
  for (int direction : {+1, -1}) {
    for (double u : {1200.0, 1545.0, 1800.0}) {
      const double from_below = ServoMap::JointAngle(p, direction, u, +1);
      const double unknown = ServoMap::JointAngle(p, direction, u, 0);
      const double from_above = ServoMap::JointAngle(p, direction, u, -1);
      // Approached from below, the joint stops short: as if the pulse were h us lower.
      EXPECT_EQ(from_below, ServoMap::JointAngle(p, direction, u - h, 0));
      EXPECT_EQ(from_above, ServoMap::JointAngle(p, direction, u + h, 0));
      EXPECT_LT(direction * from_below, direction * unknown);
      EXPECT_LT(direction * unknown, direction * from_above);
      EXPECT_NEAR(from_above - from_below, 2 * h * ServoMap::Slope(p, direction, u, 0), 1e-5);
    }
  }
}

TEST(ServoMap, SlopeIsTheDerivative) {
  std::mt19937 rng(23);
  for (int trial = 0; trial < 50; ++trial) {
    const auto p = RandomMap(rng);
    for (double u : {1100.0, 1500.0, 1900.0}) {
      const double h = 1e-3;
      const double numeric =
          (ServoMap::JointAngle(p.data(), 1, u + h, 1) - ServoMap::JointAngle(p.data(), 1, u - h, 1)) / (2 * h);
      EXPECT_NEAR(ServoMap::Slope(p.data(), 1, u, 1), numeric, 1e-10);
    }
  }
}

struct ServoAngleCost {
  int direction;
  double u_us;
  int approach;
  template <typename T>
  bool operator()(const T* params, T* angle) const {
    angle[0] = ServoMap::JointAngle(params, direction, u_us, approach);
    return true;
  }
};

TEST(ServoMap, AutodiffJacobiansMatchNumeric) {
  std::mt19937 rng(24);
  for (int trial = 0; trial < 30; ++trial) {
    const auto p = RandomMap(rng);
    for (int approach : {-1, 0, 1}) {
      const ServoAngleCost f{trial % 2 ? 1 : -1, 1000.0 + 33.3 * trial, approach};
      ceres::AutoDiffCostFunction<ServoAngleCost, 1, ServoMap::kNumParams> cost(new ServoAngleCost(f));
      EXPECT_EQ(testing::GradientCheck(cost, {p.data()}), "") << "trial " << trial;
    }
  }
}

TEST(ServoMap, DoubleAndJetAgree) {
  using J = ceres::Jet<double, ServoMap::kNumParams>;
  std::mt19937 rng(25);
  for (int trial = 0; trial < 50; ++trial) {
    const auto p = RandomMap(rng);
    J pj[ServoMap::kNumParams];
    for (int i = 0; i < ServoMap::kNumParams; ++i) pj[i] = J(p[i], i);
    const double u = 1000 + 10 * trial;
    const J a = ServoMap::JointAngle(pj, -1, u, 1);
    EXPECT_NEAR(a.a, ServoMap::JointAngle(p.data(), -1, u, 1), 1e-15);
    // d angle / d centre = -slope (moving the centre up is moving u down).
    EXPECT_NEAR(a.v[0], -ServoMap::Slope(p.data(), -1, u, 1), 1e-12);
  }
}

// The gradient check itself must be able to fail: a cost with a deliberately wrong Jacobian.
class WrongJacobianCost : public ceres::SizedCostFunction<1, 2> {
 public:
  bool Evaluate(double const* const* x, double* r, double** jac) const override {
    r[0] = x[0][0] * x[0][0] + 3 * x[0][1];
    if (jac && jac[0]) {
      jac[0][0] = 2 * x[0][0];
      jac[0][1] = 3.001;  // wrong by 0.03 %
    }
    return true;
  }
};

TEST(GradientCheck, CatchesAWrongJacobian) {
  WrongJacobianCost cost;
  const double x[2] = {1.5, -2};
  const std::string log = testing::GradientCheck(cost, {x});
  EXPECT_NE(log, "");
  EXPECT_NE(log.find("col 1"), std::string::npos) << log;
  EXPECT_EQ(log.find("col 0"), std::string::npos) << log;
}

}  // namespace
}  // namespace owlcal::models
