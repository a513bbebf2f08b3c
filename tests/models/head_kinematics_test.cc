#include "models/head_kinematics.h"

#include <gtest/gtest.h>

#include "models/head_model.h"

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
