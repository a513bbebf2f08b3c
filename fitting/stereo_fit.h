#pragma once
// Stereo calibration: joint refinement of both cameras' intrinsics, the stereo extrinsics
// right_from_left (OpenCV's R, T: x_right = R * x_left + T) and one board pose per frame, from
// views of a planar target. Views are paired by frame_index; unpaired views still constrain
// their camera's intrinsics (with their own board pose).
//
// Steps: FitIntrinsics per eye (initialisation + per-eye outlier rejection), right_from_left
// initialised from the median over pairs, then one Ceres problem (residuals whitened by each
// camera's corner sigma), observability and covariance of [left params, right params, rotation
// vector (rad), T (target unit)] by the rule of fitting/observability.h (board poses
// eliminated), rectification with cv::stereoRectify
// (CALIB_ZERO_DISPARITY, alpha) and the rectified epipolar error: |y_left - y_right| of the
// same corner after cv::undistortPoints with R1/P1 and R2/P2, over every corner seen by both.
//
// Degenerate input (one eye only, no common frames, too few poses) -> ok = false and a
// message naming what cannot be determined; never throws for bad data.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "fitting/intrinsics_fit.h"
#include "fitting/result.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting {

struct StereoFitOptions {
  IntrinsicsFitOptions intrinsics;  // model, fix flags, robust loss; applied to both eyes
  int width = 640, height = 480;    // image size of each eye [px]
  bool fix_intrinsics = false;      // only R, T and board poses float (per-eye fits kept)
  std::string length_unit = "m";    // unit of the target's sizes: "m" -> baseline in mm
  double rectify_alpha = -1;        // cv::stereoRectify alpha (-1 = OpenCV's default scaling)
  int max_iterations = 200;
  // Fit the board's bow with the cameras (fitting/board_warp.h; one board for every view). Off:
  // the board is flat. owlcal calibrate turns it on (pipeline/calibrate_pipeline.h).
  bool fit_board_warp = false;

  bool Check(std::string* why) const;
};

struct StereoFit {
  bool ok = false;
  std::string message;
  IntrinsicsFit per_eye[2];             // the separate per-eye fits (initialisation)
  models::CameraIntrinsics cameras[2];  // joint estimates [kLeftEye], [kRightEye]
  models::Rigid3d right_from_left;      // x_in_right = right_from_left * x_in_left
  std::string length_unit = "m";
  std::vector<int> frame_indices;  // frames with a board pose (paired or not)
  std::vector<int> paired_frames;  // frames seen by both eyes
  // Covariance of the global parameters, in this order: left params (4+N), right params (4+N),
  // rotation vector of R [rad] (3), T [length unit] (3). Rows of fixed/undetermined are zero.
  Eigen::MatrixXd covariance;
  std::vector<std::string> param_names;  // "left.fx" ... "right.k3" "stereo.rx" "stereo.ry" "stereo.rz" "stereo.tx" ...
  std::vector<double> sigmas;            // sqrt(diag); NaN when undetermined
  std::vector<bool> determined;
  std::vector<std::string> undetermined;  // "name: why"
  double corner_sigma_px[2] = {0, 0};
  // The board's bow (options.fit_board_warp) in the target's length unit, its sigma (NaN when
  // not determined) and the span it is defined over; not in `covariance` (marginalised).
  bool board_warp_fitted = false;
  double board_warp[2] = {0, 0};
  double board_warp_sigma[2] = {0, 0};
  double rms_px[2] = {0, 0};  // per camera, sqrt(sum |e|^2 / corners)
  double rms_joint_px = 0;    // both cameras (stereoCalibrate's RMS)
  SolveSummary summary;
  std::vector<RejectedObservation> rejected;
  // Rectification (cv::stereoRectify, OpenCV's layout).
  Eigen::Matrix3d R1 = Eigen::Matrix3d::Identity(), R2 = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero(), P2 = Eigen::Matrix<double, 3, 4>::Zero();
  Eigen::Matrix4d Q = Eigen::Matrix4d::Zero();
  double rectified_dy_mean_px = 0;  // mean |y_left - y_right| after rectification
  double rectified_dy_max_px = 0;
  int rectified_num_corners = 0;
};

// left_views: eye 0, right_views: eye 1 (as from calib::GroupIntoViews).
StereoFit FitStereo(const std::vector<calib::View>& left_views,
                    const std::vector<calib::View>& right_views,
                    const StereoFitOptions& options);

// Adds left.* and right.* intrinsics, stereo.baseline_mm (or stereo.baseline_<unit>s when the
// unit is not m, e.g. stereo.baseline_squares for unit "square"), stereo.tx/ty/tz (mm or unit),
// stereo.rx_deg/ry_deg/rz_deg (rotation vector of R), rectification errors, with sigma and
// unit; fills result->cameras and result->stereo (covariance in [rad, m] only when unit is m,
// else in the target unit) and the summary.
void AppendStereoToResult(const StereoFit& fit, CalibrationResult* result);

}  // namespace owlcal::fitting
