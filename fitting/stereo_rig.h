#pragma once
// A calibrated stereo rig as ranging and check-calibration use it: the two cameras, the pose of
// the right camera in the left one (metres), the joint covariance in StereoFit's layout [left
// intrinsics, right intrinsics, rotation vector (rad), T (m)] and the two halves of the
// calibration set; read from a stereo fit, owlcal's results.json or an OpenCV file, and
// rectified with cv::stereoRectify.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting {

struct StereoRig {
  models::CameraIntrinsics cameras[2];  // [kLeftEye], [kRightEye]
  models::Rigid3d right_from_left;      // metres
  // Layout as StereoFit::covariance with T in metres; empty = unknown.
  Eigen::MatrixXd covariance;
  std::string source;  // where it came from (file or "stereo fit")
  // The two halves of the calibration set, each calibrated alone (covariance layout, T in
  // metres); empty when unknown.
  std::vector<std::vector<double>> halves;
  int NumParams() const;  // size of the covariance layout
};

// From a stereo fit; `length_unit_m` converts the fit's length unit to metres (1 for "m").
StereoRig RigFromStereoFit(const StereoFit& fit, double length_unit_m = 1.0);
// From owlcal's results.json: cameras, stereo pose, halves (diagnostics.cross_validation);
// covariance = the stereo fit's joint
// covariance (stereo.full_covariance) when the file has it, else per-parameter sigmas of
// left.* / right.* (diagonal) and result.stereo->covariance for [rotation, T].
StereoRig RigFromResult(const CalibrationResult& result);
// From an OpenCV calibration file: T in millimetres when |T| > 1 (the course's 26.0 mm
// squares), else metres. No covariance.
StereoRig RigFromOpenCv(const OpenCvStereoCalibration& c, int width = 640, int height = 480);
// Reads a rig: results.json, an OpenCV .xml/.yml/.yaml with M1..T, or intrinsics.xml whose
// folder also holds extrinsics.xml (the course's split files). Throws naming the path. A folder,
// or a file of one by its calibration-folder name (calibration.yaml, results.json ...), is read
// only when the folder's files belong to one run (fitting/calibration_folder.h CheckOneRun); a
// results.json whose verdict is unusable is refused.
StereoRig LoadStereoRig(const std::string& path);

struct Rectification {
  cv::Size size;
  cv::Mat map_x[2], map_y[2];  // cv::initUndistortRectifyMap, CV_32FC1
  cv::Matx33d R1, R2;
  cv::Matx34d P1, P2;
  double focal_px = 0;    // rectified focal length
  double baseline_m = 0;  // |T|
};
// cv::stereoRectify with CALIB_ZERO_DISPARITY and `alpha` (-1 = OpenCV's default).
Rectification RectifyRig(const StereoRig& rig, double alpha = -1);
void RemapPair(
    const Rectification& r, const cv::Mat& left, const cv::Mat& right, cv::Mat* left_rect, cv::Mat* right_rect);

// The parameter vector of a rig in the covariance layout.
std::vector<double> RigParameters(const StereoRig& rig);

}  // namespace owlcal::fitting
