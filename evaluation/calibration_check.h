#pragma once
// Checking a stereo calibration on new images of a board (as ROS's cameracheck does, plus a
// verdict): does last week's calibration still hold?
//
// With the calibration HELD FIXED (cameras and right_from_left), only one board pose per pair
// floats (left_from_target; the right view is predicted through right_from_left), so every
// pixel of disagreement is the calibration's:
//   - reprojection RMS per eye and joint, each with its sigma (RMS / sqrt(2 n), chi statistics);
//   - per-eye RMS with the eye's own board pose (intrinsics alone, extrinsics out of the way);
//   - rectified epipolar error: y_left - y_right of the same corner after cv::undistortPoints
//     with the calibration's R1/P1, R2/P2: mean (sigma = std / sqrt(n)), RMS and max.
// Then two refits on the new images find WHAT moved:
//   A. extrinsics: right_from_left (rotation vector [rad], T) free, cameras fixed;
//   B. cameras' fx fy cx cy and the extrinsics free, distortion fixed (a fixed-focus lens's
//      distortion does not drift; the new set is usually too small to determine it).
// Each refit parameter is compared with the calibration: z = (refit - calibrated) /
// sqrt(sigma_calibration^2 + sigma_refit^2), sigma_refit from the refit's covariance scaled by
// the corner noise measured in refit B (|z| > moved_sigma flags it in the tables). A
// calibration without covariance (an OpenCV file) counts with sigma_calibration = 0. Since
// fx, cx and the toe-in (or T and the rotation) trade against each other, "what moved" is
// decided one parameter at a time: each of refit B's parameters is freed ALONE and named as
// moved when it removes at least min_explained of the excess cost (fixed - refit B) with a
// significant chi-square. Near-degenerate alternatives (right.cx and stereo.ry) are both named.
// Also: the range at 1 m on the left camera's axis as the calibration triangulates a point
// that refit B says is at 1 m, with the sigma refit B's covariance gives it.
//
// Verdict "recalibrate" when the fixed calibration is worse than the new data allow, by more
// than noise and by an amount that matters:
//   joint RMS (fixed) > max_rms_ratio * RMS (refit B) + min_rms_excess_px, or
//   epipolar RMS (fixed) > max(max_epipolar_rms_px, 2 * epipolar RMS (refit B)), or
//   |range error at 1 m| > max_range_error_pct and > 3 of its sigma;
// else "still valid" (parameters that moved significantly but harmlessly are still named).
// Too few pairs -> ok = false with the reason (no verdict).
//
// Units: the target's length unit for T (metres for real boards; the rig must use the same).
#include <string>
#include <vector>

#include "calib/observation.h"
#include "evaluation/range_images_ranging.h"

namespace owlcal::evaluation {

struct CalibrationCheckOptions {
  int min_pairs = 3;
  double moved_sigma = 3.0;
  double max_rms_ratio = 1.5;
  double min_rms_excess_px = 0.1;
  double max_epipolar_rms_px = 0.5;
  // Two calibrations of one real Owl from different image sets differ by 1.5-3 % in the range
  // at 1 m (kit2020's halves: +2.5 / -3.1 %), so smaller differences are no evidence of change.
  double max_range_error_pct = 3.0;
  double single_chi2 = 10.83;  // chi-square (1 dof) for a single parameter's change: p < 0.001
  double min_explained = 0.5;  // a parameter "moved" when it alone explains this share of the disagreement
  int max_iterations = 100;
  bool Check(std::string* why) const;
};

struct CheckedParameter {
  std::string name;  // "stereo.rx_deg", "right.cx" ...
  std::string unit;
  double calibrated = 0, refit = 0;
  double sigma_calibration = 0, sigma_refit = 0;
  double z = 0;  // (refit - calibrated) / combined sigma
  bool moved = false;
};

// One parameter freed alone (board poses float too), the rest held at the calibration.
struct ParameterDiagnosis {
  std::string name, unit;
  double change = 0;         // refit - calibrated (display units: px, deg, mm)
  double explained = 0;      // share of the excess cost (fixed - refit B) this parameter alone removes
  double chi2 = 0;           // cost drop / corner sigma^2 (chi-square with 1 dof)
  bool significant = false;  // chi2 > single_chi2
};

struct CheckedView {
  int frame_index = 0;
  int num_corners[2] = {0, 0};
  double rms_px[2] = {0, 0};  // calibration fixed, joint board pose
  double mean_dy_px = 0;      // rectified y_left - y_right (calibration's rectification)
};

struct CalibrationCheck {
  bool ok = false;
  std::string message;  // why no verdict
  int num_pairs = 0, num_corners[2] = {0, 0};
  std::vector<int> unpaired_frames;

  // Calibration held fixed.
  double rms_px[2] = {0, 0}, sigma_rms_px[2] = {0, 0};
  double rms_joint_px = 0, sigma_rms_joint_px = 0;
  double mono_rms_px[2] = {0, 0};  // each eye with its own board pose
  double epipolar_mean_dy_px = 0, sigma_epipolar_mean_dy_px = 0;
  double epipolar_rms_dy_px = 0, epipolar_max_dy_px = 0;
  int epipolar_num_corners = 0;
  std::vector<CheckedView> views;

  // Refits on the new images.
  double refit_extrinsics_rms_px = 0;
  double refit_all_rms_px = 0;
  double refit_all_epipolar_rms_dy_px = 0;
  double corner_sigma_px = 0;                // from refit B
  std::vector<CheckedParameter> extrinsics;  // refit A
  std::vector<CheckedParameter> all;         // refit B
  std::vector<ParameterDiagnosis> single;    // every refit-B parameter alone, largest share first
  double range_at_1m_m = 0;                  // the calibration's range of a point refit B puts at 1 m
  double sigma_range_at_1m_m = 0;            // what the new images can tell about that range (refit B)
  bool calibration_has_covariance = false;

  std::string verdict;  // "still valid" | "recalibrate"
  std::vector<std::string> reasons;
  std::vector<std::string> moved;  // "right.cx +3.9 px alone explains 97 % of the disagreement (chi2 850)"
};

// rig: the calibration (cameras, right_from_left, optional covariance). observations: new
// images, eye 0 = left, paired by frame_index (calib::DetectImagePairs). Never throws for bad
// data (ok = false); throws std::invalid_argument for options failing Check.
CalibrationCheck CheckCalibration(const fitting::StereoRig& rig,
                                  const std::vector<calib::CornerObservation>& observations,
                                  const CalibrationCheckOptions& options = {});

}  // namespace owlcal::evaluation
