#pragma once
// OpenCV FileStorage stereo calibration files, as written by OpenCV's samples/cpp/stereo_calib.cpp
// and the Plymouth course code: M1 D1 M2 D2 (intrinsics) and R T E F R1 R2 P1 P2 Q (extrinsics),
// either in one file (owlcal's calibration.yaml) or split into intrinsics.xml / extrinsics.xml.
// Format (.yaml/.yml/.xml) follows the file extension. Reading accepts any subset of the fields
// (an absent matrix stays empty) and distortion vectors of 4, 5, 8, 12 or 14 coefficients.
//
// This is the one place that turns cameras + right_from_left into OpenCV's fields (E, F and
// the rectification by cv::stereoRectify with CALIB_ZERO_DISPARITY); every writer of those
// fields (calibration.yaml, the course's xml, ROS camera_info) goes through
// MakeOpenCvCalibration.
//
// Lengths: T, E, P2(0,3) and Q(3,2) carry the length unit of T (`length_unit`). owlcal's own
// calibration.yaml is in metres; the course's split files are in millimetres (its 26 mm
// squares: T = -64.1, Q(3,2) = 0.0156), and WriteOpenCvSplitFiles converts to mm. Each file
// states its unit in a comment and in a `length_unit` string node (ignored by the course code);
// a reader without that node guesses mm when |T| > 1.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "models/camera_model.h"

namespace owlcal::fitting {

struct OpenCvStereoCalibration {
  cv::Mat M1, D1, M2, D2;                 // camera matrices 3x3, distortion 1xN (CV_64F)
  cv::Mat R, T, E, F;                     // x_right = R x_left + T
  cv::Mat R1, R2, P1, P2, Q;              // cv::stereoRectify outputs
  int image_width = 0, image_height = 0;  // 0 when the file does not say
  std::string length_unit = "m";          // of T, E, P2(0,3), Q(3,2): "m", "mm" or a target unit
  double rectify_alpha = -1;              // the alpha R1..Q were computed with (NaN: unknown)
  // The owlcal run that wrote the file (string node `owlcal_run_id`, ignored by the course code;
  // fitting/calibration_folder.h); "" when the file carries none.
  std::string run_id;

  bool HasIntrinsics() const { return !M1.empty() && !D1.empty() && !M2.empty() && !D2.empty(); }
  bool HasExtrinsics() const { return !R.empty() && !T.empty(); }
};

// The fields from two cameras and right_from_left (translation in `length_unit`): M, D, R, T,
// E = [T]x R, F = M2^-T E M1^-1 (F(2,2) = 1), and R1 R2 P1 P2 Q from cv::stereoRectify
// (CALIB_ZERO_DISPARITY, rectify_alpha: -1 OpenCV's default scaling, 0 only valid pixels as
// ROS's camera_calibration, 1 every source pixel kept). Throws when the image sizes differ.
OpenCvStereoCalibration MakeOpenCvCalibration(const models::CameraIntrinsics& left,
                                              const models::CameraIntrinsics& right,
                                              const models::Rigid3d& right_from_left,
                                              const std::string& length_unit = "m",
                                              double rectify_alpha = -1);

// From a stereo fit (its cameras, right_from_left and length unit).
OpenCvStereoCalibration ToOpenCvCalibration(const StereoFit& fit, double rectify_alpha = -1);
// From a result: cameras (else the head's intrinsics), stereo, the stereo fit's length unit
// (diagnostics.stereo.length_unit, default m) and the run id. Throws naming the missing part.
OpenCvStereoCalibration ToOpenCvCalibration(const CalibrationResult& result, double rectify_alpha = -1);

// The same calibration with lengths in `unit` ("m" <-> "mm"; T, E, P2(0,3), Q(3,2) scaled).
// Throws when the conversion is unknown (e.g. a target unit "square").
OpenCvStereoCalibration WithLengthUnit(const OpenCvStereoCalibration& c, const std::string& unit);

// One file with every non-empty field (+ image_width/image_height), in c.length_unit, with a
// comment saying the convention and unit. Throws naming the path.
void WriteOpenCvCalibration(const std::string& path, const OpenCvStereoCalibration& c);
// The course's split files: intrinsics (M1 D1 M2 D2), extrinsics (R T E F R1 R2 P1 P2 Q), in
// millimetres (converted from c.length_unit; a unit that cannot be converted is written as it is
// and the comment says so).
void WriteOpenCvSplitFiles(const std::string& intrinsics_path,
                           const std::string& extrinsics_path,
                           const OpenCvStereoCalibration& c);

// Reads every field present. Throws naming the path (and field) if the file cannot be opened
// or a field has the wrong shape, holds a NaN or infinite value, M1/M2 is not a camera matrix
// (fx, fy > 0, last row 0 0 1), R is not a rotation, or image_width/height is not 1..16384.
OpenCvStereoCalibration ReadOpenCvCalibration(const std::string& path);
// The same from the text of a YAML or XML FileStorage file (`source` names it in errors).
OpenCvStereoCalibration ParseOpenCvCalibration(const std::string& text, const std::string& source);
// Reads the split files and merges them. Throws naming both files when they carry different
// owlcal run ids (or one carries an id and the other none): halves of two runs.
OpenCvStereoCalibration ReadOpenCvSplitFiles(const std::string& intrinsics_path, const std::string& extrinsics_path);

// A camera from M and D: 5-coefficient model when D has <= 5 entries or entries 5..7 are zero,
// else the 8-coefficient model. Returns nullopt (and why) when D holds non-zero thin-prism or
// tilt terms (entries 8..13) that models/camera_model.h cannot represent.
std::optional<models::CameraIntrinsics> CameraFromOpenCv(
    const cv::Mat& M, const cv::Mat& D, int width, int height, std::string* why = nullptr);

}  // namespace owlcal::fitting
