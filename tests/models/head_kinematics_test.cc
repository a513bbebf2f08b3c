#include "models/head_kinematics.h"

#include <gtest/gtest.h>

#include <random>

#include <ceres/autodiff_cost_function.h>

#include "models/camera_model.h"
#include "models/head_model.h"
#include "tests/models/model_test_util.h"

namespace owlcal::models {
namespace {

TEST(HeadKinematics, PointAheadShowsDisparityFocalTimesIpdOverDepth) {
  const HeadModel head = NominalHeadModel(DefaultRobotConfig());
  const JointAngles centre = head.Angles(DefaultRobotConfig().Centre());
  const double f = head.intrinsics[kLeftEye].params[0];
  for (double z : {0.25, 0.5, 1.0, 3.0}) {
    // Depth measured from the eye rotation centres (which sit 30 mm ahead of the neck axis).
    const Eigen::Vector3d x_in_base(0, 0, z + head.geometry.centre_in_head[kLeftEye].z());
    Eigen::Vector2d pl, pr;
    ASSERT_TRUE(head.Project(kLeftEye, centre, x_in_base, &pl));
    ASSERT_TRUE(head.Project(kRightEye, centre, x_in_base, &pr));
    EXPECT_NEAR(pl.x() - pr.x(), f * head.geometry.Ipd() / z, 1e-6) << "z=" << z;
    EXPECT_NEAR(pl.y(), pr.y(), 1e-9);
  }
}

TEST(HeadKinematics, NeckRotationMovesFarPointByFocalTimesTan) {
  HeadModel head = NominalHeadModel(DefaultRobotConfig());
  const double f = head.intrinsics[kLeftEye].params[0];
  JointAngles a;
  const Eigen::Vector3d far_point(0, 0, 1e9);
  Eigen::Vector2d p0, p1;
  ASSERT_TRUE(head.Project(kLeftEye, a, far_point, &p0));
  for (double theta : {-0.3, -0.1, 0.05, 0.2}) {
    a.neck_rad = theta;
    ASSERT_TRUE(head.Project(kLeftEye, a, far_point, &p1));
    // Turning right (theta > 0) makes the world move left in the image.
    EXPECT_NEAR(p1.x() - p0.x(), -f * std::tan(theta), 1e-5) << theta;
  }
}

}  // namespace
}  // namespace owlcal::models

namespace owlcal::models {
namespace {

// The full chain of one eye: pixel of a base-frame point.
// Blocks: camera params (9), cam_from_eye (7), centre_in_head (3), [pan, tilt, neck] (3), point (3).
struct EyePixelCost {
  template <typename T>
  bool operator()(
      const T* camera, const T* cam_from_eye, const T* centre, const T* joints, const T* point, T* pixel) const {
    const Eigen::Matrix<T, 3, 1> x(point[0], point[1], point[2]);
    const Eigen::Matrix<T, 3, 1> p = PointInCam(cam_from_eye, centre, joints[0], joints[1], joints[2], x);
    return Camera5::Project(camera, p.data(), pixel);
  }
};

struct RandomEye {
  double camera[9];
  double cam_from_eye[7];
  double centre[3];
  double joints[3];
  double point[3];
};

RandomEye MakeRandomEye(std::mt19937& rng) {
  std::uniform_real_distribution<double> small(-0.03, 0.03), joint(-0.4, 0.4), u(-1, 1);
  RandomEye e{{585, 583, 321, 238, -0.1, 0.05, 0.001, -0.001, 0.01}, {}, {}, {}, {}};
  Eigen::Quaterniond q = Eigen::AngleAxisd(small(rng), Eigen::Vector3d::UnitX()) *
                         Eigen::AngleAxisd(small(rng), Eigen::Vector3d::UnitY()) *
                         Eigen::AngleAxisd(small(rng), Eigen::Vector3d::UnitZ());
  Rigid3d(q, Eigen::Vector3d(small(rng) * 0.3, small(rng) * 0.3, 0.01 + small(rng) * 0.1)).ToArray(e.cam_from_eye);
  e.centre[0] = 0.0325 + small(rng) * 0.1;
  e.centre[1] = small(rng) * 0.1;
  e.centre[2] = 0.03 + small(rng) * 0.1;
  for (double& j : e.joints) j = joint(rng) * 0.5;
  // A point the eye can see: in front of the eye along its gaze, within the field of view.
  const Rigid3d base_from_head = HeadFromBase<double>(e.joints[2]).Inverse();
  const Rigid3d head_from_eye = HeadFromEye<double>(e.centre, e.joints[0], e.joints[1]);
  const Eigen::Vector3d x_in_eye(u(rng) * 0.3, u(rng) * 0.2, 1.0 + 0.8 * u(rng));
  const Eigen::Vector3d x_in_base = base_from_head * (head_from_eye * x_in_eye);
  for (int i = 0; i < 3; ++i) e.point[i] = x_in_base[i];
  return e;
}

TEST(HeadKinematics, AutodiffJacobiansMatchNumeric) {
  std::mt19937 rng(41);
  ceres::AutoDiffCostFunction<EyePixelCost, 2, 9, 7, 3, 3, 3> cost(new EyePixelCost);
  for (int trial = 0; trial < 30; ++trial) {
    const RandomEye e = MakeRandomEye(rng);
    EXPECT_EQ(testing::GradientCheck(cost, {e.camera, e.cam_from_eye, e.centre, e.joints, e.point}), "")
        << "trial " << trial;
  }
}

TEST(HeadKinematics, DoubleAndJetAgree) {
  using J = ceres::Jet<double, 3>;
  std::mt19937 rng(42);
  for (int trial = 0; trial < 30; ++trial) {
    const RandomEye e = MakeRandomEye(rng);
    double pix[2];
    ASSERT_TRUE(EyePixelCost()(e.camera, e.cam_from_eye, e.centre, e.joints, e.point, pix));
    J camera[9], pose[7], centre[3], joints[3], point[3], pixj[2];
    for (int i = 0; i < 9; ++i) camera[i] = J(e.camera[i]);
    for (int i = 0; i < 7; ++i) pose[i] = J(e.cam_from_eye[i]);
    for (int i = 0; i < 3; ++i) {
      centre[i] = J(e.centre[i]);
      joints[i] = J(e.joints[i], i);
      point[i] = J(e.point[i]);
    }
    ASSERT_TRUE(EyePixelCost()(camera, pose, centre, joints, point, pixj));
    EXPECT_NEAR(pixj[0].a, pix[0], 1e-9);
    EXPECT_NEAR(pixj[1].a, pix[1], 1e-9);
  }
}

TEST(HeadKinematics, PanRightMovesTheSceneLeftAndTiltUpMovesItDown) {
  const HeadModel head = NominalHeadModel(DefaultRobotConfig());
  const Eigen::Vector3d far_point(0, 0, 1e9);
  JointAngles a;
  Eigen::Vector2d p0, p1;
  ASSERT_TRUE(head.Project(kRightEye, a, far_point, &p0));
  EXPECT_NEAR(p0.x(), head.intrinsics[kRightEye].params[2], 1e-6);
  a.pan_rad[kRightEye] = 0.1;
  ASSERT_TRUE(head.Project(kRightEye, a, far_point, &p1));
  EXPECT_NEAR(p1.x() - p0.x(), -585 * std::tan(0.1), 1e-5);
  a.pan_rad[kRightEye] = 0;
  a.tilt_rad[kRightEye] = 0.1;
  ASSERT_TRUE(head.Project(kRightEye, a, far_point, &p1));
  EXPECT_NEAR(p1.y() - p0.y(), 585 * std::tan(0.1), 1e-5);
}

TEST(HeadKinematics, PanningTowardsAPointCentresIt) {
  // With ideal mounting the optical axis is the gaze: pan = atan2(x, z), tilt = atan2(-y, r)
  // relative to the eye centre put any point on the principal point.
  const HeadModel head = NominalHeadModel(DefaultRobotConfig());
  std::mt19937 rng(43);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Vector3d x(u(rng) * 0.5, u(rng) * 0.3, 1.5 + u(rng));
    JointAngles a;
    a.neck_rad = 0.2 * u(rng);
    const Eigen::Vector3d x_in_head = HeadFromBase(a.neck_rad) * x;
    for (int e = 0; e < 2; ++e) {
      const Eigen::Vector3d d = x_in_head - head.geometry.centre_in_head[e];
      a.pan_rad[e] = std::atan2(d.x(), d.z());
      a.tilt_rad[e] = std::atan2(-d.y(), std::hypot(d.x(), d.z()));
      Eigen::Vector2d px;
      ASSERT_TRUE(head.Project(Eye(e), a, x, &px));
      EXPECT_NEAR(px.x(), head.intrinsics[e].params[2], 1e-9);
      EXPECT_NEAR(px.y(), head.intrinsics[e].params[3], 1e-9);
    }
  }
}

TEST(Rigid3, InverseComposeAndMapRoundTrip) {
  std::mt19937 rng(44);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(3 * u(rng), Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized()));
    const Rigid3d t(q, Eigen::Vector3d(u(rng), u(rng), u(rng)));
    const Eigen::Vector3d x(u(rng), u(rng), u(rng));
    EXPECT_NEAR((t.Inverse() * (t * x) - x).norm(), 0, 1e-12);
    EXPECT_NEAR(((t * t.Inverse()).Matrix() - Eigen::Matrix4d::Identity()).norm(), 0, 1e-12);
    double block[7];
    t.ToArray(block);
    for (int i = 0; i < 4; ++i) block[i] *= 2.5;  // Map normalises the quaternion
    EXPECT_NEAR((Rigid3d::Map(block) * x - t * x).norm(), 0, 1e-12);
    EXPECT_NEAR((t.Matrix().topLeftCorner<3, 3>() * x + t.translation - t * x).norm(), 0, 1e-12);
  }
}

}  // namespace
}  // namespace owlcal::models
