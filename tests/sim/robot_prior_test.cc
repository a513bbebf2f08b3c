// The prior's other kinds of robot (sim/robot_prior.h): reassembled robots and slow ones. Each
// drawn truth validates (DrawRobot throws otherwise), has its kind's documented properties against
// its robot file, keeps the prior robot's other values, and is the same for the same seed.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "sim/robot_prior.h"

namespace owlcal::sim {
namespace {

TEST(RobotPriorKinds, ReassembledRobotsHaveOneReversedHornAndStopsInsideTheFile) {
  std::mt19937_64 rng(21);
  int eye_reversed = 0, neck_reversed = 0, centres_below = 0, centres_above = 0;
  for (int i = 0; i < 80; ++i) {
    const RobotTruth t = DrawRobot(&rng, "r" + std::to_string(i), RobotKind::kReassembled).truth;
    int reversed = 0;
    for (int s = 0; s < models::kNumServos; ++s) {
      SCOPED_TRACE(std::string(models::kServoNames[s]) + " of robot " + std::to_string(i));
      const bool neck = s == models::kNeck;
      const ServoTruth& v = t.servos[s];
      const models::ServoConfig& c = t.robot.servos[s];
      if (v.direction != c.direction) {
        ++reversed;
        (neck ? neck_reversed : eye_reversed) += 1;
      }
      const double off = v.centre_us - c.centre_us;
      EXPECT_GE(std::abs(off), neck ? 40 : 50);
      EXPECT_LE(std::abs(off), neck ? 70 : 90);
      (off < 0 ? centres_below : centres_above) += 1;
      for (const double inside : {v.endstop_lo_us - c.min_us, c.max_us - v.endstop_hi_us}) {
        EXPECT_GE(inside, neck ? 55 : 35);
        EXPECT_LE(inside, neck ? 75 : 90);
      }
      EXPECT_EQ(v.quantum_us, 5);
    }
    EXPECT_EQ(reversed, 1) << "robot " << i;
    const double ipd_x =
        t.geometry.centre_in_head[models::kRightEye].x() - t.geometry.centre_in_head[models::kLeftEye].x();
    EXPECT_GE(ipd_x, 0.062);
    EXPECT_LE(ipd_x, 0.069);
  }
  // Every kind of horn comes up: the eyes' most often, the neck's too.
  EXPECT_GT(eye_reversed, 50);
  EXPECT_GT(neck_reversed, 0);
  EXPECT_GT(centres_below, 50);
  EXPECT_GT(centres_above, 50);
}

TEST(RobotPriorKinds, SlowRobotsHaveSlowServosASlowStreamAndARationalLens) {
  std::mt19937_64 rng(22);
  int fps15 = 0, fps20 = 0;
  for (int i = 0; i < 60; ++i) {
    const RobotTruth t = DrawRobot(&rng, "s" + std::to_string(i), RobotKind::kSlow).truth;
    SCOPED_TRACE("robot " + std::to_string(i));
    for (int s = 0; s < models::kNumServos; ++s) {
      const bool neck = s == models::kNeck;
      const ServoTruth& v = t.servos[s];
      const models::ServoConfig& c = t.robot.servos[s];
      EXPECT_EQ(v.direction, c.direction);
      EXPECT_GE(v.slew_deg_per_s, 150);
      EXPECT_LE(v.slew_deg_per_s, 250);
      EXPECT_GE(v.lag_s, 0.06);
      EXPECT_LE(v.lag_s, 0.14);
      EXPECT_GE(v.hysteresis_us, neck ? 5 : 2.5);
      EXPECT_LE(v.hysteresis_us, neck ? 7 : 4);
      EXPECT_GE(v.dead_band_us, 3);
      EXPECT_LE(v.dead_band_us, 7);
      if (neck) {
        for (const double inside : {v.endstop_lo_us - c.min_us, c.max_us - v.endstop_hi_us}) {
          EXPECT_GE(inside, 30);
          EXPECT_LE(inside, 50);
        }
      }
    }
    EXPECT_TRUE(t.stream.fps == 15 || t.stream.fps == 20) << t.stream.fps;
    (t.stream.fps == 15 ? fps15 : fps20) += 1;
    EXPECT_GE(t.stream.latency_ms, 180);
    EXPECT_LE(t.stream.latency_ms, 260);
    EXPECT_GE(t.stream.eye_offset_ms, 15);
    EXPECT_LE(t.stream.eye_offset_ms, 30);
    EXPECT_GE(t.stream.rolling_shutter_ms, 30);
    EXPECT_LE(t.stream.rolling_shutter_ms, 45);
    EXPECT_GE(t.socket.rim_half_angle_deg, 70);
    EXPECT_LE(t.socket.rim_half_angle_deg, 78);
    for (int e = 0; e < 2; ++e) {
      const models::CameraIntrinsics& k = t.intrinsics[e];
      ASSERT_EQ(k.model, models::DistortionModel::kOpenCv8);
      ASSERT_EQ(k.params.size(), 12u);
      EXPECT_GE(k.params[0], 500);  // fx [px]
      EXPECT_LE(k.params[0], 530);
      EXPECT_NEAR(k.params[1] / k.params[0], 1, 0.003);
      EXPECT_GE(k.params[4], 6);  // k1
      EXPECT_LE(k.params[4], 8);
      EXPECT_GE(k.params[9] - k.params[4], 0.8);  // k4 - k1
      EXPECT_LE(k.params[9] - k.params[4], 1.2);
      for (const int zero : {5, 8, 10, 11}) EXPECT_EQ(k.params[zero], 0);  // k2 k3 k5 k6
      EXPECT_LE(std::abs(k.params[6]), 0.001);                             // p1, p2
      EXPECT_LE(std::abs(k.params[7]), 0.001);
    }
  }
  EXPECT_GT(fps15, 15);
  EXPECT_GT(fps20, 15);
}

TEST(RobotPriorKinds, EachKindStartsFromThePriorRobotOfTheSameSeedAndRepeats) {
  for (const uint64_t seed : {1, 2, 3}) {
    std::mt19937_64 a(seed), b(seed), c(seed), d(seed);
    const DrawnRobot prior = DrawRobot(&a, "x");
    const DrawnRobot explicit_prior = DrawRobot(&b, "x", RobotKind::kPrior);
    const DrawnRobot reassembled = DrawRobot(&c, "x", RobotKind::kReassembled);
    const DrawnRobot slow = DrawRobot(&d, "x", RobotKind::kSlow);
    EXPECT_EQ(RobotTruthYaml(prior.truth), RobotTruthYaml(explicit_prior.truth));
    // Values neither kind replaces are the prior robot's.
    for (const DrawnRobot* r : {&reassembled, &slow}) {
      EXPECT_EQ(r->truth.stream.jpeg_quality, prior.truth.stream.jpeg_quality);
      EXPECT_EQ(r->truth.stream.noise_sigma, prior.truth.stream.noise_sigma);
      EXPECT_EQ(r->truth.geometry.cam_from_eye[0].translation, prior.truth.geometry.cam_from_eye[0].translation);
      EXPECT_EQ(r->scene.Find("chessboard")->warp_m, prior.scene.Find("chessboard")->warp_m);
    }
    // Each kind replaces only its own values.
    EXPECT_EQ(reassembled.truth.intrinsics[1].params, prior.truth.intrinsics[1].params);
    EXPECT_EQ(reassembled.truth.stream.fps, prior.truth.stream.fps);
    EXPECT_EQ(slow.truth.servos[models::kRx].centre_us, prior.truth.servos[models::kRx].centre_us);
    EXPECT_EQ(slow.truth.servos[models::kLy].endstop_hi_us, prior.truth.servos[models::kLy].endstop_hi_us);
    EXPECT_EQ(slow.truth.geometry.centre_in_head[0], prior.truth.geometry.centre_in_head[0]);
    // Deterministic for a seed.
    for (const RobotKind kind : {RobotKind::kReassembled, RobotKind::kSlow}) {
      std::mt19937_64 e(seed), f(seed);
      EXPECT_EQ(RobotTruthYaml(DrawRobot(&e, "y", kind).truth), RobotTruthYaml(DrawRobot(&f, "y", kind).truth))
          << RobotKindName(kind);
    }
  }
}

}  // namespace
}  // namespace owlcal::sim
