#pragma once
// Eye-pan servo maps from stereo calibrations taken at known pulse widths ("toe-in sets"): a
// student calibrates the stereo pair several times with the eyes panned to different PWM
// values; the relative rotation between the cameras then measures how far the eyes turned.
//
// Model (camera frame x right, y down, z forward; OpenCV's R = right_from_left). Each eye pans
// about its camera's y axis, theta positive to the robot's right, theta = direction * scale *
// (PWM - centre) (models/robot_config.h directions: +1 for Rx and Lx). Then
//   right_from_left = Ry(theta_R)^T * M * Ry(theta_L)  ->  yaw(R) = theta_L - theta_R + m
// where yaw(R) = atan2(R(0,2), R(2,2)) is R's rotation about y and m the eyes' mounting yaw
// difference. So, per set i,
//   yaw_i = c + dir_L k_L Lx_i - dir_R k_R Rx_i           [deg, k in deg/us]
// Only the relative rotation is seen, so the two centres and m merge into c; k_L and k_R
// separate only when Rx and Lx do not always move together. ScaleMode::kAuto fits one scale
// per eye when the sets determine both (sigma below `max_scale_sigma`), else one common scale
// for both eyes, and says so.
// Toe-in (converging) is Rx down and Lx up: yaw > 0.
//
// Weights: each set's yaw sigma from its stereo covariance (typically 0.01-0.03 deg). Sets
// taken at the same PWM scatter far more than that (servo repeatability, backlash, re-seating:
// about 1 deg on real Owls, docs/conventions.md, Facts), so the fit reports chi2/dof and scales the parameter
// sigmas by sqrt(chi2/dof) when it exceeds 1 (the scatter between sets then sets the sigma);
// `repeatability_deg` is the per-set scatter beyond the calibration sigma,
// sqrt(max(0, RMS residual^2 - mean sigma^2)).
// Tilt servos: sets whose Ry or Ly differ from the first set's are named in `notes` (a tilt
// changes the pan axis a little; keep the tilts fixed while capturing).
#include <string>
#include <vector>

#include "fitting/result.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct ToeInSet {
  std::string name;  // where it came from (folder or results.json)
  double rx_us = 0, ry_us = 0, lx_us = 0, ly_us = 0;
  bool ok = false;                     // has a usable stereo result
  std::string message;                 // why not
  double yaw_deg = 0;                  // yaw of right_from_left (above)
  double yaw_sigma_deg = 0;            // from the stereo covariance (rotation vector y)
  double pitch_deg = 0, roll_deg = 0;  // rotation vector x, z of right_from_left [deg]
  std::string verdict;                 // the set's verdict status, when known
};

// The yaw, pitch, roll and yaw sigma of a stereo result (result.stereo); ok = false with a
// message when the result has no stereo part or its verdict is "unusable".
ToeInSet ToeInSetFromResult(const CalibrationResult& result, const std::string& name);

enum class ScaleMode { kAuto, kPerEye, kCommon };

struct ToeInFitOptions {
  ScaleMode scale_mode = ScaleMode::kAuto;
  int rx_direction = 1, lx_direction = 1;  // robot file directions (models/robot_config.h)
  double max_scale_sigma = 0.01;           // deg/us: kAuto keeps per-eye scales below this
  bool Check(std::string* why) const;
};

struct ToeInSetResidual {
  int set = 0;                                        // index into the input
  double predicted_deg = 0, residual_deg = 0, z = 0;  // z = residual / yaw_sigma
};

struct ToeInServoFit {
  bool ok = false;
  std::string message;
  bool per_eye = false;  // one scale per eye (else common)
  double rx_deg_per_us = 0, lx_deg_per_us = 0, offset_deg = 0;
  double rx_sigma = 0, lx_sigma = 0, offset_sigma = 0;  // scaled by sqrt(chi2/dof) when > 1
  double chi2 = 0;
  int dof = 0;
  double chi2_per_dof = 0;
  double rms_residual_deg = 0;
  double repeatability_deg = 0;
  int num_sets = 0;
  std::vector<ToeInSetResidual> residuals;
  std::vector<std::string> notes;
  std::vector<Parameter> parameters;  // servo.Rx.deg_per_us, servo.Lx.deg_per_us, toe_in.offset_deg, ...
};

ToeInServoFit FitToeIn(const std::vector<ToeInSet>& sets, const ToeInFitOptions& options = {});

}  // namespace owlcal::fitting
