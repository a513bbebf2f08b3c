#include "models/vergence.h"

#include <gtest/gtest.h>

#include <random>

#include "models/head_model.h"
#include "models/rigid3.h"

namespace owlcal::models {
namespace {

constexpr double kIpd = 0.065;

// Inward angles of both eyes for a target at lateral x and depth z from the baseline midpoint.
void InwardAngles(double x, double z, double* theta_left, double* theta_right) {
  *theta_left = std::atan2(x + kIpd / 2, z);
  *theta_right = std::atan2(kIpd / 2 - x, z);
}

// Gaze ray of one eye in the plane of the baseline: eye at (+-IPD/2, 0, 0), pan about y
// (pan > 0 looks right, models/head_kinematics.h), via the kinematics' own rotation.
Eigen::Vector3d GazeDirection(double pan_rad) { return RotY(pan_rad) * Eigen::Vector3d(0, 0, 1); }

TEST(Vergence, SymmetricFormsAgree) {
  for (double z : {0.2, 0.5, 1.0, 2.0, 5.0}) {
    double tl, tr;
    InwardAngles(0, z, &tl, &tr);
    ASSERT_DOUBLE_EQ(tl, tr);
    EXPECT_NEAR(SymmetricDepth(kIpd, tl), z, 1e-9 * z);
    EXPECT_NEAR(TangentDepth(kIpd, tl, tr), z, 1e-9 * z);
    const PlanarFix fix = SineRuleFix(kIpd, tl, tr);
    EXPECT_NEAR(fix.depth, z, 1e-9 * z);
    EXPECT_NEAR(fix.lateral, 0, 1e-9);
    EXPECT_NEAR(fix.range, z, 1e-9 * z);
    const auto rays = ClosestPointOfRays(
        Eigen::Vector3d(-kIpd / 2, 0, 0), GazeDirection(tl), Eigen::Vector3d(kIpd / 2, 0, 0), GazeDirection(-tr));
    ASSERT_TRUE(rays);
    EXPECT_NEAR(rays->point.z(), z, 1e-9 * z);
    EXPECT_NEAR(rays->point.x(), 0, 1e-9);
    EXPECT_NEAR(rays->gap, 0, 1e-9);
  }
}

TEST(Vergence, AsymmetricFormsAgreeOnRandomTargets) {
  std::mt19937 rng(31);
  std::uniform_real_distribution<double> depth(0.15, 4.0), lateral(-0.5, 0.5);
  for (int trial = 0; trial < 1000; ++trial) {
    const double z = depth(rng), x = lateral(rng) * z;
    double tl, tr;
    InwardAngles(x, z, &tl, &tr);
    const double tol = 1e-9 * std::max(1.0, z);
    EXPECT_NEAR(TangentDepth(kIpd, tl, tr), z, tol);
    const PlanarFix fix = SineRuleFix(kIpd, tl, tr);
    EXPECT_NEAR(fix.depth, z, tol);
    EXPECT_NEAR(fix.lateral, x, tol);
    EXPECT_NEAR(fix.range, std::hypot(x, z), tol);
    EXPECT_NEAR(SineRuleLeftDistance(kIpd, tl, tr), std::hypot(x + kIpd / 2, z), tol);
    const auto rays = ClosestPointOfRays(
        Eigen::Vector3d(-kIpd / 2, 0, 0), GazeDirection(tl), Eigen::Vector3d(kIpd / 2, 0, 0), GazeDirection(-tr));
    ASSERT_TRUE(rays);
    EXPECT_NEAR(rays->point.x(), x, tol);
    EXPECT_NEAR(rays->point.z(), z, tol);
    EXPECT_GT(rays->s1, 0);
    EXPECT_GT(rays->s2, 0);
  }
}

TEST(Vergence, ClosestPointOfSkewRaysIsTheMidpoint) {
  // Rays along x at y = -1 and along z at y = +1 (through (2, 1, 0)): the shortest segment
  // joins (2, -1, 0) and (2, 1, 0), so the midpoint is (2, 0, 0) and the gap 2.
  const auto f = ClosestPointOfRays(
      Eigen::Vector3d(0, -1, 0), Eigen::Vector3d(3, 0, 0), Eigen::Vector3d(2, 1, -5), Eigen::Vector3d(0, 0, 0.5));
  ASSERT_TRUE(f);
  EXPECT_NEAR((f->point - Eigen::Vector3d(2, 0, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR(f->gap, 2, 1e-12);
  EXPECT_NEAR(f->s1, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(f->s2, 10, 1e-12);
  EXPECT_FALSE(ClosestPointOfRays(Eigen::Vector3d(0, 0, 0),
                                  Eigen::Vector3d(0, 0, 1),
                                  Eigen::Vector3d(1, 0, 0),
                                  Eigen::Vector3d(0, 0, 2)));  // parallel: no fix
}

// Hand computation with the guide's robot (code snippet 5: Lx and Rx centred at 1545 us,
// nominal 0.113 deg/us, design IPD 65 mm):
//   command Lx = 1565 (+20 us): the left eye turns right, inward, by 20 * 0.113 = 2.26 deg
//   command Rx = 1535 (-10 us): the right eye turns left, inward, by 10 * 0.113 = 1.13 deg
//   theta_l = 2.26 deg = 0.0394444 rad, tan = 0.0394649
//   theta_r = 1.13 deg = 0.0197222 rad, tan = 0.0197248
//   depth   Z = IPD / (tan tl + tan tr) = 0.065 / 0.0591897 = 1.09816 m
//   sine rule (Fig. 16b): D_l = IPD cos(tr) / sin(tl + tr)
//                             = 0.065 * 0.999806 / sin(3.39 deg = 0.0591667 rad)
//                             = 0.0649874 / 0.0591322 = 1.09902 m from the left eye
//   depth = D_l cos(tl) = 1.09902 * 0.999222 = 1.09816 m  (agrees with the tangent form)
//   lateral = D_l sin(tl) - IPD/2 = 1.09902 * 0.0394342 - 0.0325 = 0.01084 m (right of centre)
// Symmetric (Fig. 16a): both eyes 15 us inward: theta = 1.695 deg = 0.0295833 rad,
//   Z = (IPD/2) / tan(theta) = 0.0325 / 0.0295920 = 1.09827 m.
TEST(Vergence, ReproducesTheHandComputedGuideExample) {
  const RobotConfig robot = DefaultRobotConfig();
  const HeadModel head = NominalHeadModel(robot);
  PwmVector pwm = robot.Centre();
  pwm[kLx] = 1565;
  pwm[kRx] = 1535;
  const JointAngles a = head.Angles(pwm);
  const double tl = a.pan_rad[kLeftEye];    // left eye turns right = inward
  const double tr = -a.pan_rad[kRightEye];  // right eye turns left = inward
  EXPECT_NEAR(tl, 0.0394444, 1e-7);
  EXPECT_NEAR(tr, 0.0197222, 1e-7);
  EXPECT_NEAR(TangentDepth(robot.ipd_m, tl, tr), 1.09816, 1e-5);
  EXPECT_NEAR(SineRuleLeftDistance(robot.ipd_m, tl, tr), 1.09902, 1e-5);
  const PlanarFix fix = SineRuleFix(robot.ipd_m, tl, tr);
  EXPECT_NEAR(fix.depth, 1.09816, 1e-5);
  EXPECT_NEAR(fix.lateral, 0.01084, 1e-5);

  // The same fixation in 3-D through the head kinematics: gaze rays from the eye rotation
  // centres (30 mm ahead of the neck axis) meet 1.09816 m ahead of the baseline.
  Eigen::Vector3d origin[2], direction[2];
  for (int e = 0; e < 2; ++e) {
    const Rigid3d head_from_eye =
        HeadFromEye<double>(head.geometry.centre_in_head[e].data(), a.pan_rad[e], a.tilt_rad[e]);
    origin[e] = head_from_eye.translation;
    direction[e] = head_from_eye.rotation * Eigen::Vector3d(0, 0, 1);
  }
  const auto rays = ClosestPointOfRays(origin[kLeftEye], direction[kLeftEye], origin[kRightEye], direction[kRightEye]);
  ASSERT_TRUE(rays);
  EXPECT_NEAR(rays->point.z() - head.geometry.centre_in_head[kLeftEye].z(), fix.depth, 1e-9);
  EXPECT_NEAR(rays->point.x(), fix.lateral, 1e-9);
  EXPECT_NEAR(rays->gap, 0, 1e-12);

  pwm[kLx] = 1545 + 15;
  pwm[kRx] = 1545 - 15;
  const JointAngles s = head.Angles(pwm);
  EXPECT_NEAR(s.pan_rad[kLeftEye], 0.0295833, 1e-7);
  EXPECT_NEAR(SymmetricDepth(robot.ipd_m, s.pan_rad[kLeftEye]), 1.09827, 1e-5);
}

}  // namespace
}  // namespace owlcal::models
