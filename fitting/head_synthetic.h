#pragma once
// Synthetic data for the head problem (tests, benchmarks, Monte-Carlo checks), made directly
// with models::HeadModel::Project, independent of the renderer and of the fit's residual.
//
// The pose sequence follows the servo-sweep protocol: each eye servo stepped from low to high
// (approach +1) and back (approach -1) while the others stay at their centres, then a grid of
// combined eye poses (both eyes together, snake order), then (move_neck) the neck swept up and
// down with the eyes centred. `approach` per servo is the sign of its last change, as a real
// servo's backlash remembers it. Boards are fixed in the base frame, spread around the head so
// the eyes see one at every pose (near 0.5 m ahead, far ~1 m, and left/right/up/down ~0.7 m).
// Corners outside the image or behind the camera are dropped; views with fewer than
// min_corners corners are not emitted. Noise: Gaussian, noise_px per axis.
#include <map>
#include <random>
#include <string>
#include <vector>

#include "calib/observation.h"
#include "calib/target.h"
#include "models/head_model.h"
#include "models/rigid3.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct SyntheticHeadOptions {
  int steps_per_sweep = 8;  // pulse widths per direction per eye servo
  int grid_side = 4;        // grid_side^2 combined eye poses
  bool move_neck = true;
  int neck_steps = 6;            // per direction
  double sweep_fraction = 0.85;  // fraction of each side of the configured range that is swept
  double noise_px = 0.15;
  int min_corners = 8;
  calib::TargetDefinition board;  // default: 9 x 6 inner corners, 40 mm squares

  SyntheticHeadOptions() {
    board.cols = 9;
    board.rows = 6;
    board.square_m = 0.04;
  }
};

struct SyntheticHeadData {
  std::vector<calib::View> views;
  std::map<std::string, models::Rigid3d> base_from_target;  // truth
  std::vector<models::PwmVector> poses;                     // in sequence order
};

// A head perturbed from NominalHeadModel(robot) as a real Owl might be: eye-servo centres
// +-40 us, scales 0.10-0.125 deg/us, quad +-1 deg, cubic +-1.5 deg, hysteresis 2-4 us; neck
// scale/nonlinearity/hysteresis likewise with its centre at the robot file's (canonical);
// IPD 63.8 mm +- 0.5, eye centres 30 +- 3 mm ahead of the neck axis; mounts: roll and yaw
// ~1 deg, pitch `mount_pitch_deg_sigma` (0 = canonical gauge), offsets 15 +- 3 mm along z and
// +-3 mm across; intrinsics f 580 +- 10 px, mild distortion (opencv5). With canonical = true
// the eye centres have equal z and the left centre y is 0 (the fit's gauge, head_fit.h).
models::HeadModel PerturbedHead(const models::RobotConfig& robot,
                                std::mt19937_64* rng,
                                double mount_pitch_deg_sigma = 0.0,
                                bool canonical = true);

// Views of the fixed boards along the sweep sequence, projected through `truth`.
SyntheticHeadData SynthesizeHeadViews(const models::HeadModel& truth,
                                      const models::RobotConfig& robot,
                                      const SyntheticHeadOptions& options,
                                      std::mt19937_64* rng);

}  // namespace owlcal::fitting
