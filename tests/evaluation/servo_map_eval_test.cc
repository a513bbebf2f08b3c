#include "evaluation/servo_map_eval.h"

#include <cmath>

#include <gtest/gtest.h>

#include "fitting/distortion_field.h"
#include "fitting/head_fit.h"

namespace owlcal::evaluation {
namespace {

TEST(ServoMapErrorOverRange, AConstantAngleOffsetIsItsRmsMaxAndMean) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = models::NominalHeadModel(robot);
  models::HeadModel fitted = truth;
  const int s = models::kRx;
  // Shift the fitted Rx map by -0.05 deg everywhere (fitted - truth = -0.05 deg).
  fitted.servo_params[s] = fitting::ShiftServoMapAngle(truth.servo_params[s], truth.directions[s], 0.05 * M_PI / 180);
  const ServoMapError e = ServoMapErrorOverRange(fitted, truth, s, robot.servos[s].min_us, robot.servos[s].max_us);
  EXPECT_NEAR(e.rms_deg, 0.05, 1e-9);
  EXPECT_NEAR(e.max_abs_deg, 0.05, 1e-9);
  EXPECT_NEAR(e.mean_deg, -0.05, 1e-9);
  EXPECT_NEAR(ServoMapRmsDeg(fitted.servo_params[s].data(),
                             truth.servo_params[s].data(),
                             truth.directions[s],
                             robot.servos[s].min_us,
                             robot.servos[s].max_us),
              0.05,
              1e-9);
}

TEST(SampleServoMap, SigmaOfALinearMapFollowsItsCentreAndScale) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  fitting::CalibrationResult r;
  r.head = models::NominalHeadModel(robot);
  const int s = models::kLx;
  const models::ServoConfig& c = robot.servos[s];
  fitting::Parameter centre{"servo.Lx.centre_us", double(c.centre_us), 2.0, "us", std::nullopt, true, ""};
  fitting::Parameter scale{"servo.Lx.deg_per_us", c.nominal_deg_per_us, 1e-3, "deg/us", std::nullopt, true, ""};
  fitting::Parameter quad{"servo.Lx.quad_deg", 0, NAN, "deg", std::nullopt, false, "held"};
  r.Set(centre);
  r.Set(scale);
  r.Set(quad);
  const std::vector<ServoMapSample> m = SampleServoMap(r, c, s, &*r.head, 10);
  ASSERT_EQ(m.size(), 11u);
  EXPECT_DOUBLE_EQ(m.front().pwm_us, c.min_us);
  EXPECT_DOUBLE_EQ(m.back().pwm_us, c.max_us);
  for (const ServoMapSample& x : m) {
    // angle = direction * scale * (u - centre): sigma^2 = (scale sigma_c)^2 + ((u - centre) sigma_s)^2
    // (diagonal covariance, no joint block in the result).
    const double expect = std::hypot(c.nominal_deg_per_us * 2.0, (x.pwm_us - c.centre_us) * 1e-3);
    EXPECT_NEAR(x.sigma_deg, expect, 1e-4 * expect + 1e-9) << x.pwm_us;
    EXPECT_NEAR(x.angle_deg, x.nominal_deg, 1e-9);
    EXPECT_NEAR(x.truth_deg, x.angle_deg, 1e-12);
  }
  // No truth given: NaN, never a made-up value.
  EXPECT_TRUE(std::isnan(SampleServoMap(r, c, s, nullptr, 4)[2].truth_deg));
}

TEST(DistortionField, ZeroWithoutDistortionAndOutwardForPincushion) {
  models::CameraIntrinsics cam;  // 640x480, no distortion
  const std::vector<fitting::DistortionArrow> none = fitting::DistortionField(cam, 4, 3);
  ASSERT_EQ(none.size(), 20u);
  for (const fitting::DistortionArrow& a : none) EXPECT_NEAR(a.norm_px, 0.0, 1e-6);
  cam.params[4] = 0.2;  // k1 > 0: points move away from the centre
  const std::vector<fitting::DistortionArrow> k1 = fitting::DistortionField(cam, 4, 3);
  ASSERT_FALSE(k1.empty());
  const fitting::DistortionArrow& corner = k1.front();  // pixel (0, 0)
  EXPECT_GT(corner.norm_px, 1.0);
  EXPECT_LT(corner.dx_px, 0.0);
  EXPECT_LT(corner.dy_px, 0.0);
  EXPECT_NEAR(corner.x_pinhole_px + corner.dx_px, 0.0, 1e-6);
}

}  // namespace
}  // namespace owlcal::evaluation
