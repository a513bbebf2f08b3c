// Calibration files -> StereoRig (kept apart from the ranging so that ranging links without
// the OpenCV file reader).
#include <filesystem>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "fitting/calibration_folder.h"
#include "fitting/range_images_ranging.h"

namespace owlcal::fitting {
namespace fs = std::filesystem;

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
