#include "fitting/head_residuals.h"

#include <random>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "fitting/head_fit.h"
#include "fitting/head_synthetic.h"
#include "models/head_model.h"

namespace owlcal::fitting {
namespace {

using models::kNeck;

struct Blocks {
  std::array<double, 5> pan, tilt, neck;
  double mount[5];
  double centres[5];
  double board[7];
  std::vector<double> camera;
  double warp[2] = {0, 0};  // a flat board
};

Blocks BlocksOf(const models::HeadModel& h, int eye, const models::Rigid3d& base_from_target) {
  Blocks b;
  b.pan = h.servo_params[models::kPanServo[eye]];
  b.tilt = h.servo_params[models::kTiltServo[eye]];
  b.neck = h.servo_params[kNeck];
  const Eigen::Matrix3d r = h.geometry.cam_from_eye[eye].rotation.toRotationMatrix();
  b.mount[0] = std::atan2(r(1, 0), r(0, 0));
  b.mount[1] = std::asin(-r(2, 0));
  for (int k = 0; k < 3; ++k) b.mount[2 + k] = h.geometry.cam_from_eye[eye].translation(k);
  const auto& cl = h.geometry.centre_in_head[models::kLeftEye];
  const auto& cr = h.geometry.centre_in_head[models::kRightEye];
  b.centres[0] = cl.x();
  b.centres[1] = cl.y();
  b.centres[2] = cl.z();
  b.centres[3] = cr.x();
  b.centres[4] = cr.y();
  base_from_target.ToArray(b.board);
  b.camera = h.intrinsics[eye].params;
  return b;
}

TEST(HeadViewResidual, IsZeroAtTruthAndMatchesHeadModelProject) {
  std::mt19937_64 rng(3);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);  // canonical: mount pitch 0, equal z
  SyntheticHeadOptions opt;
  opt.noise_px = 0.0;
  opt.steps_per_sweep = 3;
  opt.grid_side = 2;
  opt.neck_steps = 2;
  const SyntheticHeadData data = SynthesizeHeadViews(truth, robot, opt, &rng);
  ASSERT_GT(data.views.size(), 20u);
  int checked = 0;
  for (const calib::View& v : data.views) {
    HeadViewResidual<models::Camera5> f;
    f.command.eye = v.eye;
    const int pan = models::kPanServo[v.eye], tilt = models::kTiltServo[v.eye];
    f.command.pan_us = v.pwm_us[pan];
    f.command.tilt_us = v.pwm_us[tilt];
    f.command.neck_us = v.pwm_us[kNeck];
    f.command.pan_direction = robot.servos[pan].direction;
    f.command.tilt_direction = robot.servos[tilt].direction;
    f.command.neck_direction = robot.servos[kNeck].direction;
    f.command.pan_approach = v.approach[pan];
    f.command.tilt_approach = v.approach[tilt];
    f.command.neck_approach = v.approach[kNeck];
    f.points_in_target = v.points_in_target;
    f.pixels = v.pixels;
    f.sigma_px = 0.15;
    Blocks b = BlocksOf(truth, v.eye, data.base_from_target.at(v.target_id));
    std::vector<double> res(f.NumResiduals());
    ASSERT_TRUE(f(
        b.pan.data(), b.tilt.data(), b.neck.data(), b.mount, b.centres, b.board, b.camera.data(), b.warp, res.data()));
    for (double r : res) ASSERT_NEAR(r, 0.0, 1e-6);
    ++checked;
  }
  EXPECT_EQ(checked, static_cast<int>(data.views.size()));
}

TEST(HeadViewResidual, PassesGradientCheck) {
  std::mt19937_64 rng(5);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel truth = PerturbedHead(robot, &rng);
  SyntheticHeadOptions opt;
  opt.steps_per_sweep = 3;
  opt.grid_side = 2;
  const SyntheticHeadData data = SynthesizeHeadViews(truth, robot, opt, &rng);
  ASSERT_FALSE(data.views.empty());
  // A view with non-zero approach on both eye servos exercises the hysteresis term.
  const calib::View& v = data.views[data.views.size() / 2];
  auto* f = new HeadViewResidual<models::Camera5>;
  f->command.eye = v.eye;
  const int pan = models::kPanServo[v.eye], tilt = models::kTiltServo[v.eye];
  f->command.pan_us = v.pwm_us[pan];
  f->command.tilt_us = v.pwm_us[tilt];
  f->command.neck_us = v.pwm_us[kNeck];
  f->command.pan_direction = robot.servos[pan].direction;
  f->command.tilt_direction = robot.servos[tilt].direction;
  f->command.neck_direction = robot.servos[kNeck].direction;
  f->command.pan_approach = 1;
  f->command.tilt_approach = -1;
  f->command.neck_approach = 1;
  f->points_in_target.assign(v.points_in_target.begin(), v.points_in_target.begin() + 6);
  f->pixels.assign(v.pixels.begin(), v.pixels.begin() + 6);
  f->sigma_px = 0.15;
  f->huber_k = 3.0;
  for (auto& px : f->pixels) px.x() += 2.0;  // some corners beyond the Huber threshold
  f->span = WarpSpan{0.05, 0.04, 0.1, 0.08};
  ceres::AutoDiffCostFunction<HeadViewResidual<models::Camera5>, ceres::DYNAMIC, 5, 5, 5, 5, 5, 7, 9, 2> cost(
      f, f->NumResiduals());
  Blocks b = BlocksOf(truth, v.eye, data.base_from_target.at(v.target_id));
  b.warp[0] = 0.6e-3;  // a bowed board: the warp block's Jacobian is checked too
  b.warp[1] = -0.3e-3;
  std::vector<const double*> params = {
      b.pan.data(), b.tilt.data(), b.neck.data(), b.mount, b.centres, b.board, b.camera.data(), b.warp};
  // Autodiff Jacobians against central differences (step 1e-6 relative), per block.
  const int nr = f->NumResiduals();
  const int sizes[8] = {5, 5, 5, 5, 5, 7, 9, 2};
  std::vector<std::vector<double>> jac(8);
  std::vector<double*> jac_ptrs;
  for (int k = 0; k < 8; ++k) {
    jac[k].resize(nr * sizes[k]);
    jac_ptrs.push_back(jac[k].data());
  }
  std::vector<double> r0(nr), rp(nr), rm(nr);
  ASSERT_TRUE(cost.Evaluate(params.data(), r0.data(), jac_ptrs.data()));
  double* mutable_params[8] = {
      b.pan.data(), b.tilt.data(), b.neck.data(), b.mount, b.centres, b.board, b.camera.data(), b.warp};
  int compared = 0;
  for (int k = 0; k < 8; ++k) {
    for (int c = 0; c < sizes[k]; ++c) {
      double& x = mutable_params[k][c];
      const double x0 = x, h = 1e-6 * std::max(1.0, std::abs(x0));
      x = x0 + h;
      ASSERT_TRUE(cost.Evaluate(params.data(), rp.data(), nullptr));
      x = x0 - h;
      ASSERT_TRUE(cost.Evaluate(params.data(), rm.data(), nullptr));
      x = x0;
      for (int r = 0; r < nr; ++r) {
        const double numeric = (rp[r] - rm[r]) / (2 * h);
        const double analytic = jac[k][r * sizes[k] + c];
        EXPECT_NEAR(analytic, numeric, 1e-5 * std::max(1.0, std::abs(numeric)))
            << "block " << k << " param " << c << " residual " << r;
        ++compared;
      }
    }
  }
  EXPECT_EQ(compared, nr * 43);
}

TEST(ShiftServoMapAngle, SubtractsAConstantAngleExactly) {
  const std::array<double, 5> p = {1545, 0.11, 0.8, -1.2, 3.0};
  for (int dir : {1, -1}) {
    for (double delta_deg : {-4.0, 0.7, 6.0}) {
      const std::array<double, 5> q = ShiftServoMapAngle(p, dir, delta_deg * M_PI / 180);
      EXPECT_EQ(q[4], p[4]);
      for (double u = 1100; u <= 2000; u += 37) {
        for (int approach : {-1, 0, 1}) {
          EXPECT_NEAR(models::ServoMap::JointAngle(q.data(), dir, u, approach),
                      models::ServoMap::JointAngle(p.data(), dir, u, approach) - delta_deg * M_PI / 180,
                      1e-12)
              << "u=" << u << " dir=" << dir;
        }
      }
    }
  }
}

TEST(CanonicalHead, ProjectsLikeTheOriginalUpToABaseFrameMotion) {
  std::mt19937_64 rng(11);
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const models::HeadModel head = PerturbedHead(robot, &rng, /*mount_pitch_deg_sigma=*/1.5, /*canonical=*/false);
  const models::HeadModel canon = CanonicalHead(head, robot.servos[kNeck].centre_us, true, Eigen::Vector3d::Zero());
  // Gauge conventions hold.
  EXPECT_NEAR(canon.geometry.centre_in_head[0].z(), canon.geometry.centre_in_head[1].z(), 1e-12);
  EXPECT_NEAR(canon.geometry.centre_in_head[0].y(), 0.0, 1e-12);
  EXPECT_NEAR(canon.ServoAngle(kNeck, robot.servos[kNeck].centre_us), 0.0, 1e-12);
  EXPECT_NEAR(canon.geometry.Ipd(), head.geometry.Ipd(), 1e-12);
  for (int e = 0; e < 2; ++e) {
    const Eigen::Matrix3d r = canon.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    EXPECT_NEAR(std::atan2(r(2, 1), r(2, 2)), 0.0, 1e-12);
  }
  // The same world, seen through both heads, differs by one rigid motion of the base frame:
  // canonical base_from_original = cam_from_base(canon)^-1 * cam_from_base(head) at any pose.
  auto cam_from_base = [](const models::HeadModel& h, int eye, const models::PwmVector& pwm) {
    const models::JointAngles a = h.Angles(pwm);
    double pose[7];
    h.geometry.cam_from_eye[eye].ToArray(pose);
    return models::Rigid3d::Map(pose) *
           models::HeadFromEye(h.geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye]).Inverse() *
           models::HeadFromBase(a.neck_rad);
  };
  const models::PwmVector p0 = robot.Centre();
  const models::Rigid3d g = cam_from_base(canon, 0, p0).Inverse() * cam_from_base(head, 0, p0);
  for (const models::PwmVector& p :
       {models::PwmVector{1400, 1700, 1600, 1300, 1500}, models::PwmVector{1700, 1300, 1450, 1800, 1800}}) {
    for (int eye : {0, 1}) {
      const models::Rigid3d diff = cam_from_base(canon, eye, p) * g * cam_from_base(head, eye, p).Inverse();
      EXPECT_NEAR(diff.translation.norm(), 0.0, 1e-9) << "eye " << eye;
      EXPECT_NEAR(diff.rotation.angularDistance(Eigen::Quaterniond::Identity()), 0.0, 1e-9) << "eye " << eye;
    }
  }
}

}  // namespace
}  // namespace owlcal::fitting
