// The pixel -> PWM map (fitting/pixel_pwm_map.h): from a head fitted on a
// synthetic servo sweep, the pulse widths it gives for a target's pixel centre that target in
// the truth head (the virtual Owl's geometry, with its backlash) within 1 px, in both eyes and
// across the image; the inverse gives back the pixel; the grid export covers both images.
#include "fitting/pixel_pwm_map.h"

#include <cmath>
#include <iostream>
#include <random>

#include <gtest/gtest.h>

#include "fitting/head_fit.h"
#include "fitting/head_synthetic.h"

namespace owlcal::fitting {
namespace {

std::array<double, models::kNumServos> ToDouble(const models::PwmVector& p) {
  std::array<double, models::kNumServos> d{};
  for (int i = 0; i < models::kNumServos; ++i) d[i] = p[i];
  return d;
}

TEST(PixelPwmMap, CentresTargetsWithinOnePixelOnTheTruthHead) {
  std::mt19937_64 rng(20261127);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadOptions so;
  so.steps_per_sweep = 6;
  so.grid_side = 4;
  so.move_neck = false;
  const SyntheticHeadData data = SynthesizeHeadViews(truth, robot, so, &rng);
  models::HeadModel init = models::NominalHeadModel(robot);
  init.intrinsics[0] = truth.intrinsics[0];
  init.intrinsics[1] = truth.intrinsics[1];
  const HeadFit fit = FitHead(data.views, robot, init, HeadFitOptions());
  ASSERT_TRUE(fit.ok) << fit.message;

  // Targets 0.6-2.5 m ahead, spread over both images; the head starts at the centre pose.
  const auto start = ToDouble(robot.Centre());
  const auto start_approach = std::array<int, models::kNumServos>{};
  std::uniform_real_distribution<double> u(-1, 1), dist(0.6, 2.5);
  std::normal_distribution<double> noise(0, 0.1);
  int tried = 0, centred = 0;
  double worst = 0;
  for (int k = 0; k < 40; ++k) {
    const models::Eye eye = k % 2 ? models::kRightEye : models::kLeftEye;
    const double d = dist(rng);
    const Eigen::Vector3d x_in_base(d * 0.35 * u(rng), d * 0.25 * u(rng), d);
    Eigen::Vector2d seen;
    ASSERT_TRUE(truth.Project(eye, truth.Angles(start, start_approach), x_in_base, &seen));
    if (seen.x() < 10 || seen.y() < 10 || seen.x() > 629 || seen.y() > 469) continue;
    const Eigen::Vector2d measured = seen + Eigen::Vector2d(noise(rng), noise(rng));
    // The target's distance from the camera, as a ranging step would give it.
    CentringOptions o;
    o.distance_m = truth.PointInCam(eye, truth.Angles(start, start_approach), x_in_base).norm();
    const Centring c = PulsesToCentre(fit.head, robot, eye, measured, start, o);
    ASSERT_TRUE(c.ok) << c.message;
    ASSERT_FALSE(c.clamped);
    EXPECT_LT(c.predicted_error_px, 0.9) << "1 us rounding is at most 0.5 us per servo";
    // The virtual Owl moves: the truth head at the rounded command, on the side it approached.
    auto moved = start;
    moved[models::kPanServo[eye]] = c.pan_cmd_us;
    moved[models::kTiltServo[eye]] = c.tilt_cmd_us;
    std::array<int, models::kNumServos> approach{};
    for (int i = 0; i < models::kNumServos; ++i) approach[i] = moved[i] > start[i] ? 1 : (moved[i] < start[i] ? -1 : 0);
    Eigen::Vector2d after;
    ASSERT_TRUE(truth.Project(eye, truth.Angles(moved, approach), x_in_base, &after));
    const Eigen::Vector2d centre(truth.intrinsics[eye].params[2], truth.intrinsics[eye].params[3]);
    const double err = (after - centre).norm();
    worst = std::max(worst, err);
    ++tried;
    centred += err <= 1.0;
    EXPECT_LT(err, 1.0) << models::kEyeNames[eye] << " target seen at " << seen.transpose() << " commanded "
                        << c.pan_cmd_us << " " << c.tilt_cmd_us << " lands at " << after.transpose();
    // The inverse: the exact pulse widths centre the measured pixel.
    const auto back = PixelCentredBy(fit.head, eye, c.pan_us, c.tilt_us, start, o.distance_m);
    ASSERT_TRUE(back.has_value());
    EXPECT_LT((*back - measured).norm(), 0.01);
  }
  std::cout << centred << " of " << tried << " targets centred within 1 px; worst " << worst << " px\n";
  EXPECT_GE(tried, 30);
}

TEST(PixelPwmMap, GridCoversBothImagesAndClampsToTheLimits) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel head = models::NominalHeadModel(robot);
  const PixelPwmGrid g = MakePixelPwmGrid(head, robot, 80);
  EXPECT_EQ(g.cols, 9);  // 0, 80, ..., 560 and 639
  EXPECT_EQ(g.rows, 7);  // 0, 80, ..., 400 and 479
  ASSERT_EQ(g.rows_data.size(), size_t(2 * g.cols * g.rows));
  for (const auto& r : g.rows_data) {
    EXPECT_TRUE(r.ok) << r.eye << " " << r.x_px << " " << r.y_px;
    // The principal point needs no move; the right of the image needs the pan servo to move by
    // about atan(dx / f) / 0.113 deg per us (nominal head: f 585 px).
    const double expect_pan = std::atan((r.x_px - 319.5) / 585.0) * 180 / M_PI / 0.113;
    EXPECT_NEAR(std::abs(r.delta_pan_us), std::abs(expect_pan), 1.0 + 0.02 * std::abs(expect_pan));
  }
  const std::string csv = PixelPwmGridCsv(g);
  EXPECT_NE(csv.find("eye,x_px,y_px,ok,clamped,pan_us,tilt_us,delta_pan_us,delta_tilt_us"), std::string::npos);
  // Far outside the view (a pixel the eye could only centre beyond its range) is clamped.
  const Centring c = PulsesToCentre(head, robot, models::kLeftEye, {5000, 240}, ToDouble(robot.Centre()));
  if (c.ok) {
    EXPECT_TRUE(c.clamped);
    EXPECT_LE(c.pan_cmd_us, robot.servos[models::kLx].max_us);
    EXPECT_GE(c.pan_cmd_us, robot.servos[models::kLx].min_us);
  }
  CentringOptions bad;
  bad.max_iterations = 0;
  EXPECT_FALSE(PulsesToCentre(head, robot, models::kLeftEye, {300, 200}, ToDouble(robot.Centre()), bad).ok);
}

}  // namespace
}  // namespace owlcal::fitting
