#pragma once
// OpenCV FileStorage stereo calibration files, as written by OpenCV's samples/cpp/stereo_calib.cpp
// and the Plymouth course code: M1 D1 M2 D2 (intrinsics) and R T E F R1 R2 P1 P2 Q (extrinsics),
// either in one file (owlcal's calibration.yaml) or split into intrinsics.xml / extrinsics.xml.
// Format (.yaml/.yml/.xml) follows the file extension. Reading accepts any subset of the fields
// (an absent matrix stays empty) and distortion vectors of 4, 5, 8, 12 or 14 coefficients.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "fitting/stereo_fit.h"
#include "models/camera_model.h"

namespace owlcal::fitting {

struct OpenCvStereoCalibration {
  cv::Mat M1, D1, M2, D2;                 // camera matrices 3x3, distortion 1xN (CV_64F)
  cv::Mat R, T, E, F;                     // x_right = R x_left + T
  cv::Mat R1, R2, P1, P2, Q;              // cv::stereoRectify outputs
  int image_width = 0, image_height = 0;  // 0 when the file does not say

  bool HasIntrinsics() const { return !M1.empty() && !D1.empty() && !M2.empty() && !D2.empty(); }
  bool HasExtrinsics() const { return !R.empty() && !T.empty(); }
};

// From a stereo fit (E and F computed from R, T and the camera matrices).
OpenCvStereoCalibration ToOpenCvCalibration(const StereoFit& fit);

// One file with every non-empty field (+ image_width/image_height). Throws naming the path.
void WriteOpenCvCalibration(const std::string& path, const OpenCvStereoCalibration& c);
// The course's split files: intrinsics (M1 D1 M2 D2), extrinsics (R T R1 R2 P1 P2 Q).
void WriteOpenCvSplitFiles(const std::string& intrinsics_path,
                           const std::string& extrinsics_path,
                           const OpenCvStereoCalibration& c);

// Reads every field present. Throws naming the path (and field) if the file cannot be opened
// or a field has the wrong shape.
OpenCvStereoCalibration ReadOpenCvCalibration(const std::string& path);
// Reads the split files and merges them.
OpenCvStereoCalibration ReadOpenCvSplitFiles(const std::string& intrinsics_path, const std::string& extrinsics_path);

// A camera from M and D: 5-coefficient model when D has <= 5 entries or entries 5..7 are zero,
// else the 8-coefficient model. Returns nullopt (and why) when D holds non-zero thin-prism or
// tilt terms (entries 8..13) that models/camera_model.h cannot represent.
std::optional<models::CameraIntrinsics> CameraFromOpenCv(const cv::Mat& M,
                                                         const cv::Mat& D,
                                                         int width,
                                                         int height,
                                                         std::string* why = nullptr);

}  // namespace owlcal::fitting
