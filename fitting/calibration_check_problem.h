#pragma once
// The Ceres problem of evaluation::CheckCalibration (evaluation/calibration_check.h), used only
// there: board poses per image pair with the calibration's parameters held or freed by a
// mask, and the solve's RMS, cost and covariance.
#include <array>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/observation.h"
#include "fitting/stereo_rig.h"
#include "models/camera_model.h"

namespace owlcal::fitting::internal::check {

// The left (view[0]) and right (view[1]) views of one frame.
struct Pair {
  int frame_index = 0;
  calib::View view[2];
};

// Which global parameters float, in the layout [left params, right params, rv (3), T (3)].
using FreeMask = std::vector<bool>;

// The rig's parameters in the check's blocks, and back.
struct Blocks {
  models::DistortionModel model[2];
  std::vector<double> camera[2];
  double right_from_left[6];
  std::vector<std::array<double, 6>> poses;  // left_from_target per pair
};

Blocks BlocksFromRig(const StereoRig& rig);
// `like` with the blocks' cameras and right_from_left, without covariance.
StereoRig RigFromBlocks(const StereoRig& like, const Blocks& b);

// OpenCV's camera matrix and distortion row of a camera.
cv::Mat CameraMatrix(const models::CameraIntrinsics& c);
cv::Mat DistCoeffs(const models::CameraIntrinsics& c);

// Board pose and RMS of one view with the camera fixed (cv::solvePnP, iterative LM).
bool PoseOfView(const models::CameraIntrinsics& cam, const calib::View& v, std::array<double, 6>* pose, double* rms);

struct SolveOutcome {
  bool ok = false;
  double rms_px[2] = {0, 0}, rms_joint_px = 0;
  double sum_sq[2] = {0, 0};
  int n[2] = {0, 0};
  int num_free = 0;
  Eigen::MatrixXd cov;  // [left params, right params, rv, T] (unit corner noise), zero rows for fixed
  std::vector<std::array<double, 2>> view_rms;
};

// Solves the board poses (and the parameters `free` floats) over the pairs, in place in b;
// the covariance of the free parameters when want_covariance.
SolveOutcome Solve(
    const std::vector<Pair>& pairs, const FreeMask& free, bool want_covariance, int max_iterations, Blocks* b);

}  // namespace owlcal::fitting::internal::check
