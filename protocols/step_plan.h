#pragma once
// The deterministic part of a protocol step, shared by the runner and the dry-run: the
// servo poses of sweeps and grids, target placement poses and prompts, and a work estimate
// for the progress ETA.
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "calib/target.h"
#include "models/robot_config.h"
#include "protocols/protocol.h"

namespace owlcal::protocols {

struct PlannedPose {
  models::PwmVector pwm_us{};
  bool capture = true;  // false: an approach move (hysteresis: reach the next point from one side)
};

// Poses of a sweep or grid step, in execution order, BEFORE the limits guard.
// Sweep: [pre-approach from - step], from .. to (every step_us, `to` included), and when
// both_directions [pre-approach to + step], to .. from. Pre-approach points are clamped to
// the servo's limits (and dropped when that makes them equal to the end). Grid: for each neck offset, each
// tilt offset, the pan offsets in serpentine order; offsets toward right/up times each
// servo's direction, added to the hold pose for the eyes selected.
std::vector<PlannedPose> PlanPoses(const SweepStep& step, const models::RobotConfig& robot);
std::vector<PlannedPose> PlanPoses(const GridStep& step, const models::RobotConfig& robot);

// base_from_target for a place-target step: the target's centre at (offset_x, offset_y,
// distance) in the base frame, rotated by R = RotY(yaw) RotX(pitch) RotZ(roll) from facing
// the robot; with a target definition the origin (first corner) is placed so that the
// pattern's centre lands there, else the origin itself does.
Eigen::Isometry3d PlacementPose(const PlaceTargetStep& step, const calib::TargetDefinition* target);
// Where targets not in use are put on a virtual robot: far to the side, out of every view.
Eigen::Isometry3d HiddenPose();
// "Place the chessboard target 600 mm in front of the neck axis ..., then press Enter".
std::string PlacementPrompt(const Protocol& protocol, const PlaceTargetStep& step);

// Rough relative cost of a step (frames it will grab), for the ETA.
double StepWork(const Step& step);

}  // namespace owlcal::protocols
