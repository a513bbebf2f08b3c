#pragma once
// Stereo calibration at any commanded head pose, from a head fit: the course
// notes tell students to recalibrate whenever the eyes move; the head fit already knows the
// camera mounts, the eye rotation centres and the servo maps, so R, T follow for any command.
//
//   x_in_right = right_from_left * x_in_left,
//   right_from_left = cam_from_eye[R] * HeadFromEye(centre[R], pan_R, tilt_R)^-1 *
//                     HeadFromEye(centre[L], pan_L, tilt_L) * cam_from_eye[L]^-1
// with the joint angles from the servo maps (models/head_model.h). The neck turns both eyes
// together and drops out. E, F and the rectification (R1 R2 P1 P2 Q) follow from R, T and the
// head's intrinsics through fitting/opencv_calib_file.h, the same code as the centre pose.
//
// Sigma: the covariance of [rotation vector of R (rad), T (m)] is J C J^T, C the head fit's
// covariance over the parameters R, T depend on (eye servo maps, eye centres, camera mounts;
// `PoseStereoParameterNames`), J by central differences. A servo whose approach side is not
// known (approach 0: the middle of its backlash band) adds its half band as a uniform error of
// the pulse width (variance (h/2)^2 / 3). Parameters the fit did not determine (other than its
// gauge conventions, which move nothing the cameras see) contribute nothing; the result overload
// lists them in `not_propagated` and as warnings.
//
// Usage:
//   const fitting::PoseStereo s = fitting::StereoAtPose(result, {1520, 1530, 1570, 1580, 1530});
//   if (s.ok) fitting::WriteOpenCvCalibration("pose.yaml", s.opencv);
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fitting/named_covariance.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct PoseStereoOptions {
  // Side of each servo's backlash band the pose was approached from (+1 from below, -1 from
  // above, 0 unknown), wire order.
  std::array<int, models::kNumServos> approach{};
  double rectify_alpha = -1;  // cv::stereoRectify alpha, as the centre pose's calibration.yaml
  bool Check(std::string* why) const;
};

struct PoseStereo {
  bool ok = false;
  std::string message;  // why not
  models::PwmVector pwm_us{};
  models::Rigid3d right_from_left;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // [rot vec (rad), T (m)]
  std::vector<std::string> propagated;                                           // head parameters in the sigma
  std::vector<std::string> not_propagated;  // ones R, T depend on that the fit did not determine
  OpenCvStereoCalibration opencv;           // M D R T E F R1 R2 P1 P2 Q, metres
  // The pose's calibration as a result (cameras = the head's intrinsics, stereo, the head, the
  // stereo.* parameters with sigma, inputs.pose), ready for reports::WriteCalibrationFiles.
  CalibrationResult result;
};

// Head parameters R, T can depend on (the covariance names of fitting/head_fit.h).
std::vector<std::string> PoseStereoParameterNames();

// Applies `delta` (in the result unit of `name`) to a head: servo.<S>.*, head.<eye>.centre_*_mm
// (head.left.centre_z_mm moves both eyes: the gauge ties them), head.<eye>.mount_{roll,yaw}_deg
// (ZYX Euler of cam_from_eye), head.<eye>.mount_{x,y,z}_mm. False for any other name.
bool PerturbHeadGeometry(const std::string& name, double delta, models::HeadModel* head);

// right_from_left at a command (approach per servo, 0 = middle of the backlash band).
models::Rigid3d RightFromLeftAtPose(const models::HeadModel& head,
                                    const std::array<double, models::kNumServos>& pwm_us,
                                    const std::array<int, models::kNumServos>& approach = {});

// From a head and the covariance of its parameters (result units). Never throws for a pose; a
// head without usable cameras gives ok = false.
PoseStereo StereoAtPose(const models::HeadModel& head,
                        const NamedCovariance& covariance,
                        const models::PwmVector& pwm_us,
                        const PoseStereoOptions& options = {});

// From a calibration result with a head fit (result.head and diagnostics.covariance, as
// owlcal calibrate writes them). ok = false, with the reason, when the result has no head.
PoseStereo StereoAtPose(const CalibrationResult& result,
                        const models::PwmVector& pwm_us,
                        const PoseStereoOptions& options = {});

}  // namespace owlcal::fitting
