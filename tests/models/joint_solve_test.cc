#include "models/joint_solve.h"

#include <gtest/gtest.h>

#include "models/robot_config.h"

namespace owlcal::models {
namespace {

// The solver finds the pan (or neck) angle the point was projected with, from another start.
TEST(SolveJointForColumn, RecoversThePanAndTheNeckThatPutAPointOnAColumn) {
  const HeadModel head = NominalHeadModel(DefaultRobotConfig());
  JointAngles truth;
  truth.pan_rad[kLeftEye] = 0.05;
  truth.neck_rad = -0.08;
  const Eigen::Vector3d x(0.1, 0.02, 0.8);
  Eigen::Vector2d px;
  ASSERT_TRUE(head.Project(kLeftEye, truth, x, &px));
  JointAngles start = truth;
  start.pan_rad[kLeftEye] = 0;
  const auto pan = SolveJointForColumn(head, kLeftEye, start, x, px.x(), ColumnJoint::kPan);
  ASSERT_TRUE(pan);
  EXPECT_NEAR(*pan, 0.05, 1e-8);
  start = truth;
  start.neck_rad = 0;
  const auto neck = SolveJointForColumn(head, kLeftEye, start, x, px.x(), ColumnJoint::kNeck);
  ASSERT_TRUE(neck);
  EXPECT_NEAR(*neck, -0.08, 1e-8);
  // A point behind the camera has no column.
  EXPECT_FALSE(SolveJointForColumn(head, kLeftEye, start, Eigen::Vector3d(0, 0, -1), 320, ColumnJoint::kPan));
}

// The one margin check every closed-loop protocol calls: names the servo, its limits and what was
// done; servos left where they were are not checked when asked.
TEST(OutsideMargin, NamesTheServoAndSkipsUnchangedOnes) {
  const RobotConfig robot = DefaultRobotConfig();
  PwmVector target = robot.Centre();
  EXPECT_EQ(OutsideMargin(robot, target, 20, "not sent"), "");
  target[kLx] = robot.servos[kLx].max_us - 10;
  EXPECT_EQ(OutsideMargin(robot, target, 20, "not sent"),
            "Lx would go to 1840 us, within 20 us of its limit [1180, 1850]: not sent");
  const PwmVector from = target;
  EXPECT_EQ(OutsideMargin(robot, target, 20, "not sent", &from), "");
}

}  // namespace
}  // namespace owlcal::models
