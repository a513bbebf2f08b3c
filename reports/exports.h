#pragma once
// Calibration exports for other tools, from ReportData (reports/report_data.h): the result
// (cameras, stereo, head), the limits evaluation and the calibration corners' residuals.
//
//   calibration.yaml     OpenCV FileStorage, fields of OpenCV's stereo sample (M1 D1 M2 D2 R T E
//                        F R1 R2 P1 P2 Q), lengths in metres, rectification alpha -1; written by
//                        fitting/opencv_calib_file.h (the one OpenCV writer).
//   intrinsics.xml,      the course's split files, lengths in millimetres (as the course's own
//   extrinsics.xml       files and code), each saying its unit in a comment and a length_unit node.
//   exports/ros_<eye>.yaml
//                        ROS camera_info (camera_calibration_parsers format): plumb_bob (5
//                        coefficients) or rational_polynomial (8); R and P from cv::stereoRectify
//                        with alpha = 0 and CALIB_ZERO_DISPARITY, as ROS's camera_calibration
//                        StereoCalibrator does (mono: P = getOptimalNewCameraMatrix(alpha 0), as
//                        its MonoCalibrator); the file states the alpha. Lengths in metres.
//   exports/kalibr_camchain.yaml
//                        cam0 = left, cam1 = right, pinhole-radtan. Radtan has k1 k2 p1 p2 only: a
//                        model with k3 (or k4..k6) is refitted to radtan4 over the whole image
//                        (fitting/radtan_refit.h) and the file states the max and RMS pixel
//                        error of the refit. cam1.T_cn_cnm1 = right_from_left (4x4, metres).
//   exports/<eye>.cameramodel
//                        mrcal: LENSMODEL_OPENCV5 / OPENCV8, intrinsics [fx fy cx cy dist...],
//                        extrinsics rt_cam_ref (ref = left camera), and the valid_intrinsics_region
//                        by mrcal's definition (fitting/projection_uncertainty.h) when the
//                        corners' residuals are known.
//   exports/owl-pwm.h    C and C++ header (static const, static inline): the guide's code
//                        snippet 5 names from the measured limits and fitted centres, every
//                        fitted servo map term with its direction, PWM -> angle and the inverse
//                        angle -> PWM that clamps to the limits. Only when servo maps were fitted.
// Writers throw std::runtime_error naming the path (or the missing part of the result).
#include <string>
#include <vector>

#include "evaluation/limits_eval.h"
#include "fitting/result.h"
#include "models/robot_config.h"
#include "reports/report_data.h"

namespace owlcal::reports {

// What each export says about itself (for the report's export table and the console).
struct ExportNote {
  std::string file;  // relative to the calibration folder
  std::string tool;  // "OpenCV", "ROS", "Kalibr", "mrcal", "C/C++"
  std::string note;  // unit, alpha, refit error, region ...
};

struct ExportSet {
  std::vector<std::string> written;  // paths
  std::vector<std::string> skipped;  // "file: reason"
  std::vector<ExportNote> notes;
};

// Why the result's cameras or stereo pose are not finite and plausible (focal lengths 0.1 to 100
// image widths, principal point within an image size of the image, distortion within 1e4, a
// finite pose), or "" when they are.
std::string ImplausibleExportValue(const fitting::CalibrationResult& result);

// Every file above into DIR (exports/ below it), after removing what an earlier writing left
// there (calibration.yaml, the xml files, exports/). Nothing it can write is left out; what it
// cannot write is listed in `skipped` with the reason. When the result has a run id, each
// OpenCV file carries it (owlcal_run_id) and exports/owlcal_run.json names the run and the
// export files written (fitting/calibration_folder.h). Throws, writing and removing nothing,
// when ImplausibleExportValue finds a value no export may carry.
ExportSet WriteCalibrationFiles(const ReportData& data, const std::string& dir);

// The single writers (the note is what the file states about itself).
std::string WriteRosCameraInfo(const fitting::CalibrationResult& result, int eye, const std::string& path);
std::string WriteKalibrCamchain(const fitting::CalibrationResult& result, const std::string& path);
std::string WriteMrcalCameraModel(const ReportData& data, int eye, const std::string& path);
// limits may be null (configured limits are used); centres come from the fitted servo maps
// (servo.<S>.centre_us) when determined, else the configured centre. Throws when no servo map
// was fitted (the header would hold nothing calibrated).
std::string OwlPwmHeaderText(const fitting::CalibrationResult& result,
                             const models::RobotConfig& config,
                             const evaluation::LimitsEvaluation* limits);
void WriteOwlPwmHeader(const fitting::CalibrationResult& result,
                       const models::RobotConfig& config,
                       const evaluation::LimitsEvaluation* limits,
                       const std::string& path);

}  // namespace owlcal::reports
