#pragma once
// Synthetic views of a flat board seen by one camera (tests, benchmarks): random board poses
// around a nominal distance, the corners projected with models::CameraIntrinsics::Project,
// independent of the fits' residuals. Head data: fitting/head_synthetic.h.
#include <random>

#include "calib/observation.h"
#include "calib/target.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting {

// Where the board's centre goes, in the camera frame: x = centre_x + spread_x * u, y =
// spread_y * u, z = depth + spread_z * u (u uniform in [-1, 1]); its tilt about a random axis
// in [tilt_min, tilt_min + tilt_range] rad.
struct BoardPoseSpread {
  double centre_x_m = 0, spread_x_m = 0.12, spread_y_m = 0.09;
  double depth_m = 0.45, spread_z_m = 0.12;
  double tilt_min_rad = 0.15, tilt_range_rad = 0.45;
};

// cam_from_target of one random board pose (7 uniform draws from rng).
models::Rigid3d RandomBoardPose(const calib::TargetDefinition& board, const BoardPoseSpread& spread, std::mt19937* rng);

// The corners of `board` that `cam` sees from cam_from_target inside its width x height image,
// each pixel with Gaussian noise of noise_px per axis (two draws per corner). The view's frame,
// eye and target_id are left for the caller to set.
calib::View ProjectBoardView(const models::CameraIntrinsics& cam,
                             const calib::TargetDefinition& board,
                             const models::Rigid3d& cam_from_target,
                             double noise_px,
                             std::mt19937* rng);

}  // namespace owlcal::fitting
