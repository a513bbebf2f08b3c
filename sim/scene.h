#pragma once
// The virtual Owl's world: calibration targets at poses in the base frame
// (models/head_kinematics.h: origin on the neck axis at eye height, x right, y down,
// z forward) in front of a textured background wall.
//
// Scene file (YAML, data/sim/scene_*.yaml):
//   background: {distance_m: 3.0, texel_m: 0.004, contrast: 0.35, seed: 7, grey: 0.55}
//   targets:
//     - name: chessboard            # unique; SceneControl moves targets by name
//       kind: chessboard            # chessboard | aprilgrid | fixation
//       cols: 9, rows: 6, square_m: 0.026                       # chessboard
//       tag_cols: 6, tag_rows: 6, tag_size_m: 0.024, tag_spacing: 0.3, first_id: 0  # aprilgrid
//       fixation_radius_m: 0.01                                  # fixation (black disc)
//       pose: {t_m: [x, y, z], rpy_deg: [roll, pitch, yaw]}  # or q_xyzw: [..4]
//       pose: {centre_m: [x, y, z], rpy_deg: [...]}   # or: where the pattern's CENTRE is (FacingPose)
//       visible: true
//       motion: {speed_m_s: 0.01, angular_speed_deg_s: 1.0, seed: 3}   # held by a person
//       warp_m: [0.001, 0]            # board bow (SceneTarget::warp_m)
// The pose is base_from_target (calib/target.h target frame: origin at the first corner, x
// along the columns, y down the rows, z into the board). rpy_deg = [roll, pitch, yaw]:
// R = Ry(yaw) Rx(pitch) Rz(roll) with the base axes (y down, x right, z forward): yaw turns the
// board about the vertical (positive: its face turns towards +x, so a board to the robot's
// right at yaw = atan2(x, z) faces the robot), pitch tilts it about x, roll spins it in its
// plane. All zero = the board upright, facing the robot.
// Corner ids and positions of a rendered target are exactly TargetDefinition::Corners().
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "calib/target.h"

namespace owlcal::sim {

// How a target moves about its placed pose: still (propped on a stand, the default) or held by
// a person. A held target sways and trembles: each axis of its translation and rotation (in the
// target frame) is a sum of sinusoids at hand frequencies (0.7, 1.6, 3.1 and 8.7 Hz, carrying
// 40/30/20/10 % of the speed variance) with phases drawn from `seed`, scaled so the RMS speeds
// are speed_m_s and angular_speed_deg_s. Bounded: the RMS excursion is about speed / 6 Hz.
struct TargetMotion {
  double speed_m_s = 0;
  double angular_speed_deg_s = 0;
  uint64_t seed = 0;
  bool Still() const { return speed_m_s <= 0 && angular_speed_deg_s <= 0; }
  // target_from_moved at time t_ns (identity when still).
  Eigen::Isometry3d Offset(int64_t t_ns) const;
};

struct SceneTarget {
  calib::TargetDefinition definition;                                  // definition.id is the target's name
  Eigen::Isometry3d base_from_target = Eigen::Isometry3d::Identity();  // placed (nominal) pose
  bool visible = true;
  TargetMotion motion;
  // Board warp, mrcal's 2-parameter model: the surface lies at target z = -(warp_m.x (1 - u^2) +
  // warp_m.y (1 - v^2)), u and v running from -1 to 1 across the corner grid (WarpSpan) along
  // target x and y; positive values bow the middle towards the camera. Zero = flat. A real
  // course board bows by about 1 mm along its long side (fitted on kit2020 and darvill2019).
  Eigen::Vector2d warp_m = Eigen::Vector2d::Zero();
  const std::string& name() const { return definition.id; }
  // min/max x, y of the corners in the target frame (the warp's span).
  Eigen::Vector4d WarpSpan() const;
  // A corner's true position on the warped board (points_in_target of the flat board + the warp).
  Eigen::Vector3d WarpedPoint(const Eigen::Vector3d& point_in_target) const;
  // Where the target is at time t_ns: base_from_target * motion.Offset(t_ns).
  Eigen::Isometry3d PoseAt(int64_t t_ns) const;
};

struct Background {
  double distance_m = 3.0;  // a wall facing the robot at z = distance_m in the base frame
  double texel_m = 0.004;   // texel size of its random texture
  double contrast = 0.35;
  double grey = 0.55;  // mean brightness (0 black .. 1 white)
  uint64_t seed = 7;
};

struct SceneDescription {
  Background background;
  std::vector<SceneTarget> targets;

  SceneTarget* Find(const std::string& name);
  const SceneTarget* Find(const std::string& name) const;
  // The scene frozen at time t_ns: every moving target at its pose then, motion removed.
  SceneDescription At(int64_t t_ns) const;
};

// The course's kit-box board bows about 0.9 mm towards the camera along its long side
// (SceneTarget::warp_m; fitted on kit2020 and darvill2019 sessions 1-3: 0.84-1.0 mm).
inline constexpr double kCourseBoardWarpM = 0.9e-3;

// The built-in scene: a 9x6 chessboard (26 mm, bowed kCourseBoardWarpM like the course's)
// 0.6 m ahead, a 6x6 AprilGrid to the right, four tag sheets around the boards (above and
// below each side), a fixation disc to the left, in front of a textured wall at 3 m.
SceneDescription DefaultScene();
// One of the default scene's tag sheets: a 6x2 tag36h11 AprilGrid of 45 mm tags, spacing 0.25.
calib::TargetDefinition TagSheetDefinition(const std::string& name, int first_id);
SceneDescription LoadScene(const std::string& path);
nlohmann::json SceneJson(const SceneDescription& scene);
// Largest |x|, |y| or |z| of a target's position in the base frame [m]: the scene holds a target
// within 1 km of the head (a hidden target sits 50 m away), so a larger offset is a typo.
inline constexpr double kMaxTargetOffset_m = 1e3;
// A pose as JSON: {"t_m": [..3], "q_xyzw": [..4]}; PoseFromJson also accepts "rpy_deg".
nlohmann::json PoseJson(const Eigen::Isometry3d& pose);
// Throws std::invalid_argument naming the field when the JSON is not a pose.
Eigen::Isometry3d PoseFromJson(const nlohmann::json& j);
// base_from_target for a board whose CENTRE sits at centre_in_base, facing the robot
// (its z axis pointing away from the robot), turned by yaw/pitch/roll [deg].
Eigen::Isometry3d FacingPose(const calib::TargetDefinition& def,
                             const Eigen::Vector3d& centre_in_base,
                             double yaw_deg = 0,
                             double pitch_deg = 0,
                             double roll_deg = 0);

}  // namespace owlcal::sim
