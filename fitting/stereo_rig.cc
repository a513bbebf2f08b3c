#include "fitting/stereo_rig.h"

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "fitting/calibration_folder.h"

namespace owlcal::fitting {
namespace {

namespace fs = std::filesystem;

cv::Mat RangingCameraMatrix(const models::CameraIntrinsics& c) {
  return (cv::Mat_<double>(3, 3) << c.params[0], 0, c.params[2], 0, c.params[1], c.params[3], 0, 0, 1);
}
cv::Mat RangingDistCoeffs(const models::CameraIntrinsics& c) {
  const auto d = c.Distortion();
  return cv::Mat(d, true).reshape(1, 1);
}

}  // namespace

int StereoRig::NumParams() const { return static_cast<int>(cameras[0].params.size() + cameras[1].params.size()) + 6; }

std::vector<double> RigParameters(const StereoRig& rig) {
  std::vector<double> p = rig.cameras[0].params;
  p.insert(p.end(), rig.cameras[1].params.begin(), rig.cameras[1].params.end());
  const Eigen::AngleAxisd aa(rig.right_from_left.rotation);
  const Eigen::Vector3d rv = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) p.push_back(rv[i]);
  for (int i = 0; i < 3; ++i) p.push_back(rig.right_from_left.translation[i]);
  return p;
}

StereoRig RigFromStereoFit(const StereoFit& fit, double length_unit_m) {
  StereoRig rig;
  rig.cameras[0] = fit.cameras[0];
  rig.cameras[1] = fit.cameras[1];
  rig.right_from_left = fit.right_from_left;
  rig.right_from_left.translation *= length_unit_m;
  rig.covariance = fit.covariance;
  const int n = rig.NumParams();
  if (rig.covariance.rows() == n && rig.covariance.cols() == n) {
    // Scale the T rows/columns to metres.
    rig.covariance.middleRows(n - 3, 3) *= length_unit_m;
    rig.covariance.middleCols(n - 3, 3) *= length_unit_m;
  } else {
    rig.covariance.resize(0, 0);
  }
  rig.source = "stereo fit";
  return rig;
}

namespace {

void ReadHalves(const CalibrationResult& r, StereoRig* rig) {
  if (!r.diagnostics.contains("cross_validation")) return;
  const auto& cv = r.diagnostics.at("cross_validation");
  if (!cv.contains("halves") || !cv.at("halves").is_array()) return;
  for (const auto& h : cv.at("halves")) {
    const auto q = h.get<std::vector<double>>();
    if (static_cast<int>(q.size()) == rig->NumParams()) rig->halves.push_back(q);
  }
  if (rig->halves.size() != 2) rig->halves.clear();
}

}  // namespace

StereoRig RigFromResult(const CalibrationResult& r) {
  if (!r.cameras[0] || !r.cameras[1] || !r.stereo)
    throw std::runtime_error("result has no stereo calibration (cameras and stereo pose needed)");
  StereoRig rig;
  rig.cameras[0] = *r.cameras[0];
  rig.cameras[1] = *r.cameras[1];
  rig.right_from_left = r.stereo->right_from_left;
  const int n = rig.NumParams();
  rig.source = "results.json";
  ReadHalves(r, &rig);
  if (r.stereo->full_covariance.rows() == n && r.stereo->full_covariance.cols() == n) {
    rig.covariance = r.stereo->full_covariance;  // with the correlations (same layout)
    return rig;
  }
  // An older or partial result: per-parameter sigmas (correlations lost) and the pose block.
  rig.covariance = Eigen::MatrixXd::Zero(n, n);
  int k = 0;
  for (int e = 0; e < 2; ++e) {
    const auto names = IntrinsicParamNames(rig.cameras[e].model);
    for (const auto& name : names) {
      const Parameter* p = r.Find(std::string(e == 0 ? "left." : "right.") + name);
      if (p && p->determined && std::isfinite(p->sigma)) rig.covariance(k, k) = p->sigma * p->sigma;
      ++k;
    }
  }
  rig.covariance.block(n - 6, n - 6, 6, 6) = r.stereo->covariance;
  rig.source = "results.json (per-parameter sigmas: correlations unknown)";
  return rig;
}

Rectification RectifyRig(const StereoRig& rig, double alpha) {
  Rectification r;
  r.size = cv::Size(rig.cameras[0].width, rig.cameras[0].height);
  const cv::Mat K1 = RangingCameraMatrix(rig.cameras[0]), K2 = RangingCameraMatrix(rig.cameras[1]);
  const cv::Mat D1 = RangingDistCoeffs(rig.cameras[0]), D2 = RangingDistCoeffs(rig.cameras[1]);
  const Eigen::Matrix3d Re = rig.right_from_left.rotation.toRotationMatrix();
  cv::Mat R(3, 3, CV_64F), T(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) R.at<double>(i, j) = Re(i, j);
    T.at<double>(i) = rig.right_from_left.translation[i];
  }
  cv::Mat R1, R2, P1, P2, Q;
  cv::stereoRectify(K1, D1, K2, D2, r.size, R, T, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, alpha, r.size);
  r.R1 = cv::Matx33d(R1);
  r.R2 = cv::Matx33d(R2);
  r.P1 = cv::Matx34d(P1);
  r.P2 = cv::Matx34d(P2);
  r.focal_px = r.P1(0, 0);
  r.baseline_m = rig.right_from_left.translation.norm();
  cv::initUndistortRectifyMap(K1, D1, R1, P1, r.size, CV_32FC1, r.map_x[0], r.map_y[0]);
  cv::initUndistortRectifyMap(K2, D2, R2, P2, r.size, CV_32FC1, r.map_x[1], r.map_y[1]);
  return r;
}

void RemapPair(const Rectification& r, const cv::Mat& left, const cv::Mat& right, cv::Mat* lr, cv::Mat* rr) {
  cv::remap(left, *lr, r.map_x[0], r.map_y[0], cv::INTER_LINEAR);
  cv::remap(right, *rr, r.map_x[1], r.map_y[1], cv::INTER_LINEAR);
}

StereoRig RigFromOpenCv(const OpenCvStereoCalibration& c, int width, int height) {
  if (!c.HasIntrinsics() || !c.HasExtrinsics()) throw std::runtime_error("OpenCV calibration lacks M1 D1 M2 D2 R T");
  StereoRig rig;
  const int w = c.image_width > 0 ? c.image_width : width, h = c.image_height > 0 ? c.image_height : height;
  std::string why;
  auto l = CameraFromOpenCv(c.M1, c.D1, w, h, &why);
  if (!l) throw std::runtime_error("M1/D1: " + why);
  auto rr = CameraFromOpenCv(c.M2, c.D2, w, h, &why);
  if (!rr) throw std::runtime_error("M2/D2: " + why);
  rig.cameras[0] = *l;
  rig.cameras[1] = *rr;
  // Lengths in metres: the file's stated unit (owlcal writes one), else the reader's guess
  // (the course writes mm: 26 mm squares).
  const OpenCvStereoCalibration cm = WithLengthUnit(c, "m");
  cv::Mat R, T;
  cm.R.convertTo(R, CV_64F);
  cm.T.convertTo(T, CV_64F);
  if (R.rows == 1 || R.cols == 1) cv::Rodrigues(R.clone(), R);
  Eigen::Matrix3d Re;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Re(i, j) = R.at<double>(i, j);
  Eigen::Vector3d t(T.at<double>(0), T.at<double>(1), T.at<double>(2));
  rig.right_from_left = models::Rigid3d(Eigen::Quaterniond(Re).normalized(), t);
  rig.source = "OpenCV file";
  return rig;
}

StereoRig LoadStereoRig(const std::string& path) {
  fs::path p(path);
  if (fs::is_directory(p)) {
    if (fs::exists(p / "results.json")) return LoadStereoRig((p / "results.json").string());
    if (fs::exists(p / "intrinsics.xml")) return LoadStereoRig((p / "intrinsics.xml").string());
    throw std::runtime_error(path + ": folder holds neither results.json nor intrinsics.xml");
  }
  if (!fs::exists(p)) throw std::runtime_error(path + ": no such calibration file");
  // A file of a calibration folder is read only when the folder holds one run.
  CheckOneRunOfPath(path);
  StereoRig rig;
  if (p.extension() == ".json") {
    const CalibrationResult result = ReadResultJson(path);
    // The numbers of an unusable set are refused where they are made (no calibration.yaml or
    // exports); its results.json is for reading why, not for measuring.
    if (result.verdict.is_object() && result.verdict.value("status", "") == "unusable") {
      std::string reason = "see its verdict";
      if (result.verdict.contains("reasons") && result.verdict.at("reasons").is_array() &&
          !result.verdict.at("reasons").empty() && result.verdict.at("reasons")[0].is_string())
        reason = result.verdict.at("reasons")[0].get<std::string>();
      throw std::runtime_error(path + ": the calibration's verdict is unusable (" + reason +
                               "); calibrate with a better set of views");
    }
    rig = RigFromResult(result);
    rig.source = path + " (" + rig.source + ")";
    return rig;
  } else if (p.filename() == "intrinsics.xml" && fs::exists(p.parent_path() / "extrinsics.xml")) {
    rig = RigFromOpenCv(ReadOpenCvSplitFiles(path, (p.parent_path() / "extrinsics.xml").string()));
  } else {
    rig = RigFromOpenCv(ReadOpenCvCalibration(path));
  }
  rig.source = path;
  return rig;
}

}  // namespace owlcal::fitting
