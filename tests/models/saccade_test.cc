#include "models/saccade.h"

#include <gtest/gtest.h>

namespace owlcal::models {
namespace {

HeadModel Head() {
  HeadModel h = NominalHeadModel(DefaultRobotConfig());
  h.servo_params[kRx] = {1560, 0.108, 0.6, -1.2, 2};
  h.servo_params[kRy] = {1500, 0.118, -0.5, 0.8, 1.5};
  h.geometry.cam_from_eye[kRightEye] =
      Rigid3d::Map(std::array<double, 7>{0.004, -0.003, 0.005, 1, 0.001, -0.001, -0.015}.data());
  h.intrinsics[kRightEye].params = {587, 586, 317, 243, -0.1, 0.07, 0, 0, -0.016};
  return h;
}

// A target seen off-centre is centred exactly by the pulses SaccadePulses returns (with the
// backlash of the move), at the range it is at.
TEST(Saccade, PulsesCentreTheTargetWithBacklash) {
  const HeadModel h = Head();
  const std::array<double, kNumServos> pwm = {1470, 1500, 1545, 1580, 1530};
  const JointAngles a = h.Angles(pwm, {1, 1, 0, 0, 0});
  const Eigen::Vector3d target(0.12, -0.03, 0.9);
  Eigen::Vector2d px;
  ASSERT_TRUE(h.Project(kRightEye, a, target, &px));
  ASSERT_GT(std::abs(px.x() - 317), 50);
  const auto x = PointAtPixel(h, kRightEye, a, px, (target - Eigen::Vector3d(0.032, 0, 0.03)).norm());
  ASSERT_TRUE(x);
  const auto p = SaccadePulses(h, kRightEye, a, *x, true, true, {1, -1});
  ASSERT_TRUE(p);
  auto after = pwm;
  after[kRx] = (*p)[0];
  after[kRy] = (*p)[1];
  Eigen::Vector2d centred;
  ASSERT_TRUE(h.Project(kRightEye, h.Angles(after, {1, -1, 0, 0, 0}), target, &centred));
  EXPECT_NEAR(centred.x(), 317, 0.3);  // the camera-to-eye offset makes the range matter a little
  EXPECT_NEAR(centred.y(), 243, 0.3);
  // Pan only: the tilt stays.
  const auto q = SaccadePulses(h, kRightEye, a, *x, true, false, {1, 1});
  ASSERT_TRUE(q);
  EXPECT_NEAR((*q)[1], 1500, 1e-6);
}

TEST(Saccade, ShapedStepSettlesSoonerThanAPlainStep) {
  // 10 deg at 0.113 deg/us, 380 deg/s, 25 ms lag, a 0.2 deg band.
  const double a = 10 / 0.113, slew = 380 / 0.113, band = 0.2 / 0.113;
  const SaccadeShape s = ShapeSaccade(a, slew, 0.025, band);
  const SaccadeShape plain = ShapeSaccade(a, slew, 1e-9, band);
  EXPECT_GT(s.overdrive_us, 0);
  EXPECT_GT(s.switch_s, 0);
  EXPECT_LT(s.settle_s, 0.06);  // a plain step needs ~0.112 s with this lag
  EXPECT_LT(plain.settle_s, 0.03);
  // The joint really is inside the band from settle_s on.
  double r1 = 0;
  const double y1 = SlewLagState(0, 0, a + s.overdrive_us, slew, 0.025, s.switch_s, &r1);
  for (double t = s.settle_s + 0.001; t < 0.5; t += 0.001) {
    const double y = t < s.switch_s ? SlewLagState(0, 0, a + s.overdrive_us, slew, 0.025, t)
                                    : SlewLagState(r1, y1, a, slew, 0.025, t - s.switch_s);
    EXPECT_LE(std::abs(y - a), band + 1e-9) << t;
  }
}

}  // namespace
}  // namespace owlcal::models
