#pragma once
// Calibration exports for other tools, from a fitting::CalibrationResult (cameras, stereo,
// head) and, for the course header, the limits evaluation.
//
//   WriteOpenCvYaml      OpenCV FileStorage YAML with the fields of OpenCV's stereo sample
//                        (samples/cpp/stereo_calib.cpp) and the course code: M1 D1 M2 D2 R T E F
//                        R1 R2 P1 P2 Q, image_width, image_height. x_right = R x_left + T, T in
//                        metres. Rectification by cv::stereoRectify (CALIB_ZERO_DISPARITY, alpha -1).
//   WriteRosCameraInfo   ROS camera_info YAML (camera_calibration_parsers format) for one eye:
//                        plumb_bob (5 coefficients) or rational_polynomial (8), R and P of the
//                        rectification when stereo is known.
//   WriteKalibrCamchain  Kalibr camchain YAML: cam0 = left, cam1 = right, pinhole-radtan
//                        (k1 k2 p1 p2; a non-zero k3 is dropped with a comment: radtan has 4),
//                        cam1.T_cn_cnm1 = right_from_left (4x4, metres).
//   WriteMrcalCameraModel mrcal .cameramodel: LENSMODEL_OPENCV5 / OPENCV8, intrinsics
//                        [fx fy cx cy dist...], extrinsics rt_cam_ref (ref = left camera:
//                        zeros for the left, rotation vector + translation [m] for the right).
//   WriteOwlPwmHeader    owl-pwm.h: the guide's code snippet 5 variables (RyB RyT RxR RxL LyB
//                        LyT LxR LxL NeckR NeckL RxC RyC LxC LyC NeckC and the *Range values)
//                        from the measured limits and fitted centres, plus OWLCAL_* macros with
//                        the fitted scales [deg/us] and IPD [mm].
// All throw std::runtime_error naming the path (or the missing part of the result).
#include <string>

#include <opencv2/core.hpp>

#include "fitting/limits_eval.h"
#include "fitting/result.h"
#include "models/robot_config.h"

namespace owlcal::reports {

struct OpenCvStereoFields {
  cv::Mat M1, D1, M2, D2, R, T, E, F, R1, R2, P1, P2, Q;
  cv::Size image_size;
};

// Builds the fields from result.cameras and result.stereo (throws when either is missing).
OpenCvStereoFields MakeOpenCvStereoFields(const fitting::CalibrationResult& result);

void WriteOpenCvYaml(const fitting::CalibrationResult& result, const std::string& path);
void WriteRosCameraInfo(const fitting::CalibrationResult& result, int eye, const std::string& path);
void WriteKalibrCamchain(const fitting::CalibrationResult& result, const std::string& path);
void WriteMrcalCameraModel(const fitting::CalibrationResult& result, int eye, const std::string& path);
// limits may be null (configured limits are used); centres come from the fitted servo maps
// (servo.<S>.centre_us) when determined, else the configured centre.
std::string OwlPwmHeaderText(const fitting::CalibrationResult& result,
                             const models::RobotConfig& config,
                             const fitting::LimitsEvaluation* limits);
void WriteOwlPwmHeader(const fitting::CalibrationResult& result,
                       const models::RobotConfig& config,
                       const fitting::LimitsEvaluation* limits,
                       const std::string& path);

// Writes every export the result supports into DIR: calibration.yaml (OpenCV) one level up
// is written by the caller; here ros_left.yaml, ros_right.yaml, kalibr_camchain.yaml,
// left.cameramodel, right.cameramodel, owl-pwm.h. Returns the paths written; skipped parts
// are appended to `skipped` with the reason.
std::vector<std::string> WriteAllExports(const fitting::CalibrationResult& result,
                                         const models::RobotConfig& config,
                                         const fitting::LimitsEvaluation* limits,
                                         const std::string& dir,
                                         std::vector<std::string>* skipped);

}  // namespace owlcal::reports
