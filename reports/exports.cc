#include "reports/exports.h"

#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "fitting/calibration_folder.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/pixel_pwm_map.h"
#include "fitting/projection_uncertainty.h"
#include "fitting/radtan_refit.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "reports/owl_pwm_header.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

const models::CameraIntrinsics& Camera(const fitting::CalibrationResult& r, int eye) {
  if (r.cameras[eye]) return *r.cameras[eye];
  if (r.head) return r.head->intrinsics[eye];
  throw std::runtime_error(std::string("export: the result has no ") + models::kEyeNames[eye] + " camera");
}

std::string Num(double v) { return Fmt(v, 12); }

std::string List(const cv::Mat& m) {
  std::ostringstream o;
  for (int i = 0; i < m.rows; ++i)
    for (int j = 0; j < m.cols; ++j) o << (i || j ? ", " : "") << Num(m.at<double>(i, j));
  return o.str();
}

std::string StereoUnit(const fitting::CalibrationResult& r) {
  if (r.diagnostics.contains("stereo") && r.diagnostics["stereo"].contains("length_unit"))
    return r.diagnostics["stereo"]["length_unit"].get<std::string>();
  return "m";
}

// ROS, Kalibr and mrcal take metres.
void RequireMetres(const fitting::CalibrationResult& r, const std::string& path) {
  if (StereoUnit(r) != "m")
    throw std::runtime_error("export " + path + ": the stereo translation is in '" + StereoUnit(r) +
                             "', not metres (give the target's size in metres)");
}

// The observed corner sigma of one eye: the stereo fit's, else the RMS residual per axis.
double ObservedSigma(const ReportData& d, int eye) {
  const auto& diag = d.result.diagnostics;
  const char* name = models::kEyeNames[eye];
  if (diag.contains("stereo") && diag["stereo"].contains("corner_sigma_px") &&
      diag["stereo"]["corner_sigma_px"].contains(name))
    return diag["stereo"]["corner_sigma_px"][name].get<double>();
  double s = 0;
  int n = 0;
  for (const auto& p : d.residuals)
    if (p.eye == eye) {
      s += p.dx * p.dx + p.dy * p.dy;
      n += 2;
    }
  return n ? std::sqrt(s / n) : NAN;
}

// The parameters held by an option (calibrate-images --fix) for a comment and the export
// notes: "held by --fix (not fitted): left.k3 = 0, right.k3 = 0", or "".
std::string HeldNote(const fitting::CalibrationResult& r) {
  std::string s;
  for (const auto& p : r.parameters)
    if (p.held) s += (s.empty() ? "" : ", ") + p.name + " = " + Fmt(p.value, 6);
  return s.empty() ? s : "held by --fix (not fitted): " + s;
}

std::string HeldComment(const fitting::CalibrationResult& r) {
  const std::string n = HeldNote(r);
  return n.empty() ? n : "# owlcal: " + n + "\n";
}

}  // namespace

std::string WriteRosCameraInfo(const fitting::CalibrationResult& r, int eye, const std::string& path) {
  const auto& c = Camera(r, eye);
  cv::Mat K = (cv::Mat_<double>(3, 3) << c.params[0], 0, c.params[2], 0, c.params[1], c.params[3], 0, 0, 1);
  cv::Mat D(c.Distortion(), true);
  D = D.reshape(1, 1);
  cv::Mat Rr = cv::Mat::eye(3, 3, CV_64F), P = cv::Mat::zeros(3, 4, CV_64F);
  std::string how;
  if (r.stereo) {
    RequireMetres(r, path);
    // ROS camera_calibration's StereoCalibrator: cv2.stereoRectify(..., alpha=0.0), default
    // flags (CALIB_ZERO_DISPARITY).
    const fitting::OpenCvStereoCalibration f = fitting::ToOpenCvCalibration(r, 0.0);
    Rr = eye == models::kLeftEye ? f.R1 : f.R2;
    P = eye == models::kLeftEye ? f.P1 : f.P2;
    how =
        "stereo rectification: cv::stereoRectify, CALIB_ZERO_DISPARITY, alpha = 0 (as ROS camera_calibration's "
        "StereoCalibrator; only valid pixels in the rectified image); P[0,3] = -fx' * baseline [m]";
  } else {
    // ROS's MonoCalibrator: P = getOptimalNewCameraMatrix(K, D, size, alpha 0), R = I.
    cv::getOptimalNewCameraMatrix(K, D, cv::Size(c.width, c.height), 0.0).copyTo(P(cv::Rect(0, 0, 3, 3)));
    how = "monocular: P = cv::getOptimalNewCameraMatrix(K, D, alpha = 0) as ROS camera_calibration's MonoCalibrator";
  }
  std::ostringstream o;
  o << "# ROS camera_info (camera_calibration_parsers YAML), written by owlcal " << r.software_version << "\n"
    << "# " << how << "\n"
    << HeldComment(r) << "image_width: " << c.width << "\nimage_height: " << c.height << "\n"
    << "camera_name: owl_" << models::kEyeNames[eye] << "\n"
    << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << List(K) << "]\n"
    << "distortion_model: " << (c.NumDistortion() == 5 ? "plumb_bob" : "rational_polynomial") << "\n"
    << "distortion_coefficients:\n  rows: 1\n  cols: " << D.cols << "\n  data: [" << List(D) << "]\n"
    << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [" << List(Rr) << "]\n"
    << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [" << List(P) << "]\n";
  WriteTextFile(path, o.str());
  return r.stereo ? "rectification alpha = 0 (as ROS's calibrator), metres" : "monocular, alpha = 0";
}

std::string WriteKalibrCamchain(const fitting::CalibrationResult& r, const std::string& path) {
  if (!r.stereo) throw std::runtime_error("export " + path + ": the result has no stereo estimate");
  RequireMetres(r, path);
  std::ostringstream o, note;
  o << "# Kalibr camchain, written by owlcal " << r.software_version
    << ". cam0 = left eye, cam1 = right eye; pinhole-radtan (k1 k2 p1 p2).\n"
    << HeldComment(r);
  for (int e = 0; e < 2; ++e) {
    const auto& c = Camera(r, e);
    const fitting::RadtanRefit fit = fitting::FitRadtan4(c);
    if (!fit.ok) throw std::runtime_error("export " + path + ": " + models::kEyeNames[e] + " eye: " + fit.message);
    const auto d = fit.camera.Distortion();
    o << "cam" << e << ":\n";
    if (e == 1) {
      const Eigen::Matrix4d T = r.stereo->right_from_left.Matrix();
      o << "  T_cn_cnm1:\n";
      for (int i = 0; i < 4; ++i)
        o << "  - [" << Num(T(i, 0)) << ", " << Num(T(i, 1)) << ", " << Num(T(i, 2)) << ", " << Num(T(i, 3)) << "]\n";
    }
    if (fit.exact) {
      o << "  # owlcal: the fitted model has no k3..k6: radtan represents it exactly\n";
      note << (e ? "; " : "") << models::kEyeNames[e] << ": exact";
    } else {
      o << "  # owlcal: radtan cannot represent the fitted k3" << (c.NumDistortion() > 5 ? " and k4..k6" : "")
        << "; k1 k2 p1 p2 refitted over the whole image (fx fy cx cy kept): max error " << Fmt(fit.max_error_px, 3)
        << " px, RMS " << Fmt(fit.rms_error_px, 3) << " px over " << fit.num_points << " image points\n";
      note << (e ? "; " : "") << models::kEyeNames[e] << ": radtan4 refit, max " << Fmt(fit.max_error_px, 3)
           << " px, RMS " << Fmt(fit.rms_error_px, 3) << " px";
    }
    o << "  camera_model: pinhole\n"
      << "  intrinsics: [" << Num(c.params[0]) << ", " << Num(c.params[1]) << ", " << Num(c.params[2]) << ", "
      << Num(c.params[3]) << "]\n"
      << "  distortion_model: radtan\n"
      << "  distortion_coeffs: [" << Num(d[0]) << ", " << Num(d[1]) << ", " << Num(d[2]) << ", " << Num(d[3]) << "]\n"
      << "  resolution: [" << c.width << ", " << c.height << "]\n"
      << "  rostopic: /owl/" << models::kEyeNames[e] << "/image_raw\n"
      << "  cam_overlaps: [" << (1 - e) << "]\n";
  }
  WriteTextFile(path, o.str());
  return note.str();
}

std::string WriteMrcalCameraModel(const ReportData& d, int eye, const std::string& path) {
  const fitting::CalibrationResult& r = d.result;
  const auto& c = Camera(r, eye);
  double rt[6] = {0, 0, 0, 0, 0, 0};
  if (eye == models::kRightEye) {
    if (!r.stereo) throw std::runtime_error("export " + path + ": the result has no stereo estimate");
    RequireMetres(r, path);
    const Eigen::AngleAxisd aa(r.stereo->right_from_left.rotation);
    const Eigen::Vector3d rv = aa.axis() * aa.angle();
    for (int i = 0; i < 3; ++i) {
      rt[i] = rv[i];
      rt[3 + i] = r.stereo->right_from_left.translation[i];
    }
  }
  // The valid-intrinsics region from the residuals of this eye's calibration corners.
  std::vector<fitting::CornerResidual> res;
  for (const auto& p : d.residuals)
    if (p.eye == eye) res.push_back({p.x, p.y, p.dx, p.dy});
  std::ostringstream o, note;
  o << "# generated by owlcal " << r.software_version << ": the " << models::kEyeNames[eye]
    << " eye; reference frame = left camera\n";
  std::vector<Eigen::Vector2d> region;
  bool have_region = false;
  if (!res.empty()) {
    const double sigma = ObservedSigma(d, eye);
    const fitting::ValidIntrinsicsRegion v =
        fitting::ComputeValidIntrinsicsRegion(c, fitting::IntrinsicsCovariance(r, eye), res, sigma);
    region = v.contour;
    have_region = true;
    o << "# valid_intrinsics_region: mrcal's definition (mrcal-calibrate-cameras defaults 1 0.5 1.5 3 0): cells of a "
      << v.uncertainty.nx << "x" << v.uncertainty.ny
      << " grid with projection uncertainty at infinity < 1 x the observed "
      << "corner sigma (" << Fmt(sigma, 3) << " px), |mean residual| < 0.5 px, residual stdev < 1.5 x sigma and more "
      << "than 3 residuals; " << Fmt(100 * v.valid_fraction, 3) << " % of the cells are valid\n";
    note << "valid_intrinsics_region: " << Fmt(100 * v.valid_fraction, 3) << " % of the image";
  } else {
    o << "# no valid_intrinsics_region: the calibration corners' residuals are not in this result\n";
    note << "no valid_intrinsics_region (no corner residuals)";
  }
  o << HeldComment(r) << "{\n    'lensmodel':  '"
    << (c.NumDistortion() == 5 ? "LENSMODEL_OPENCV5" : "LENSMODEL_OPENCV8") << "',\n"
    << "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,.... (OpenCV order)\n    'intrinsics': [ ";
  for (size_t i = 0; i < c.params.size(); ++i) o << (i ? ", " : "") << Num(c.params[i]);
  o << " ],\n";
  if (have_region) {
    o << "    'valid_intrinsics_region': [\n";
    for (const auto& p : region) o << "    [ " << Num(p.x()) << ", " << Num(p.y()) << " ],\n";
    o << "    ],\n";
  }
  o << "    # extrinsics are rt_fromref: rotation vector [rad], translation [m]\n    'extrinsics': [ ";
  for (int i = 0; i < 6; ++i) o << (i ? ", " : "") << Num(rt[i]);
  o << " ],\n    'imagersize': [ " << c.width << ", " << c.height << " ],\n}\n";
  WriteTextFile(path, o.str());
  return note.str();
}

std::string OwlPwmHeaderText(const fitting::CalibrationResult& r,
                             const models::RobotConfig& config,
                             const evaluation::LimitsEvaluation* limits) {
  return OwlPwmHeader(r, config, limits);
}

void WriteOwlPwmHeader(const fitting::CalibrationResult& r,
                       const models::RobotConfig& config,
                       const evaluation::LimitsEvaluation* limits,
                       const std::string& path) {
  WriteTextFile(path, OwlPwmHeaderText(r, config, limits));
}

std::string ImplausibleExportValue(const fitting::CalibrationResult& r) {
  auto text = [](double v) { return io::SignificantText(v, 6); };
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics* c = r.cameras[e] ? &*r.cameras[e] : r.head ? &r.head->intrinsics[e] : nullptr;
    if (!c) continue;
    const std::string eye = models::kEyeNames[e];
    if (c->width <= 0 || c->height <= 0 || c->params.size() < 4)
      return eye + " camera: image size " + std::to_string(c->width) + "x" + std::to_string(c->height) + " or " +
             std::to_string(c->params.size()) + " parameters is not a camera";
    static const char* const kNames[] = {"fx", "fy", "cx", "cy"};
    for (size_t i = 0; i < c->params.size(); ++i)
      if (!std::isfinite(c->params[i]))
        return eye + " camera parameter " + (i < 4 ? kNames[i] : "k" + std::to_string(i - 3)) + " is not finite";
    // Focal lengths from a tenth to a hundred times the image width; the principal point within
    // an image width or height of the image; distortion coefficients within 1e4.
    const double w = c->width, h = c->height;
    for (int i = 0; i < 2; ++i)
      if (!(c->params[i] >= 0.1 * w && c->params[i] <= 100 * w))
        return eye + " camera " + kNames[i] + " = " + text(c->params[i]) + " px is not plausible for a " +
               std::to_string(c->width) + " px wide image (0.1 to 100 widths)";
    if (!(std::abs(c->params[2] - w / 2) <= 1.5 * w && std::abs(c->params[3] - h / 2) <= 1.5 * h))
      return eye + " camera principal point (" + text(c->params[2]) + ", " + text(c->params[3]) +
             ") px is more than an image size outside the image";
    for (size_t i = 4; i < c->params.size(); ++i)
      if (std::abs(c->params[i]) > 1e4)
        return eye + " camera distortion k" + std::to_string(i - 3) + " = " + text(c->params[i]) + " is not plausible";
  }
  if (r.stereo) {
    const models::Rigid3d& p = r.stereo->right_from_left;
    if (!p.translation.allFinite() || !p.rotation.coeffs().allFinite() || p.translation.norm() > 1e6 ||
        std::abs(p.rotation.norm() - 1) > 1e-6)
      return "stereo right_from_left (t = " + text(p.translation.norm()) +
             " length units) is not a finite, plausible pose";
  }
  return "";
}

ExportSet WriteCalibrationFiles(const ReportData& d, const std::string& dir) {
  ExportSet out;
  const fitting::CalibrationResult& r = d.result;
  if (const std::string why = ImplausibleExportValue(r); !why.empty())
    throw std::runtime_error(dir + "/results.json: " + why + "; no calibration.yaml or exports written from it");
  // What an earlier writing left goes before this one writes, so that no export of another
  // result survives whatever this one writes or skips.
  const std::string ex = dir + "/exports";
  for (const char* f : {"calibration.yaml", "intrinsics.xml", "extrinsics.xml"}) std::filesystem::remove(dir + "/" + f);
  std::filesystem::remove_all(ex);
  std::filesystem::create_directories(ex);
  auto attempt = [&](const std::string& rel, const std::string& tool, auto&& fn) {
    const std::string path = dir + "/" + rel;
    try {
      const std::string held = HeldNote(r);
      const std::string note = fn(path) + (held.empty() ? "" : "; " + held);
      out.written.push_back(path);
      out.notes.push_back({rel, tool, note});
    } catch (const std::exception& e) {
      out.skipped.push_back(rel + ": " + e.what());
    }
  };
  attempt("calibration.yaml", "OpenCV", [&](const std::string& p) {
    const fitting::OpenCvStereoCalibration c = fitting::WithLengthUnit(fitting::ToOpenCvCalibration(r, -1), "m");
    fitting::WriteOpenCvCalibration(p, c);
    return std::string("lengths in metres; rectification alpha = -1 (OpenCV's default scaling)");
  });
  attempt("intrinsics.xml", "OpenCV (course)", [&](const std::string& p) {
    const fitting::OpenCvStereoCalibration c = fitting::ToOpenCvCalibration(r, -1);
    fitting::WriteOpenCvSplitFiles(p, dir + "/extrinsics.xml", c);
    out.written.push_back(dir + "/extrinsics.xml");
    return std::string("with extrinsics.xml: the course's files, lengths in ") +
           (c.length_unit == "m" || c.length_unit == "mm" || c.length_unit == "cm" ? "millimetres" : c.length_unit);
  });
  for (int e = 0; e < 2; ++e) {
    const std::string eye = models::kEyeNames[e];
    attempt("exports/ros_" + eye + ".yaml", "ROS", [&](const std::string& p) { return WriteRosCameraInfo(r, e, p); });
    attempt("exports/" + eye + ".cameramodel", "mrcal", [&](const std::string& p) {
      return WriteMrcalCameraModel(d, e, p);
    });
  }
  attempt("exports/kalibr_camchain.yaml", "Kalibr", [&](const std::string& p) { return WriteKalibrCamchain(r, p); });
  attempt("exports/owl-pwm.h", "C/C++", [&](const std::string& p) {
    WriteOwlPwmHeader(r, d.config, d.limits ? &*d.limits : nullptr, p);
    return std::string("limits, centres, servo maps and the pixel -> PWM map; valid C99 and C++");
  });
  attempt("exports/pixel_pwm.csv", "CSV", [&](const std::string& p) {
    if (!r.head || !r.Find("servo.Lx.deg_per_us") || !r.Find("servo.Lx.deg_per_us")->determined)
      throw std::runtime_error("no eye servo map was fitted (no servo sweep in this calibration)");
    WriteTextFile(p, fitting::PixelPwmGridCsv(fitting::MakePixelPwmGrid(*r.head, d.config, 40)));
    return std::string("pixel -> PWM map: pan/tilt pulse widths that centre each pixel, every 40 px, centre pose");
  });
  // Last: the run the exports belong to, and which they are (fitting/calibration_folder.h).
  if (!r.run_id.empty()) {
    nlohmann::json files = nlohmann::json::array();
    for (const auto& p : out.written)
      if (std::filesystem::path(p).parent_path() == std::filesystem::path(ex))
        files.push_back(std::filesystem::path(p).filename().string());
    const nlohmann::json run = {{"format", "owlcal-exports"}, {"run_id", r.run_id}, {"files", files}};
    const std::string path = dir + "/" + fitting::kExportsRunFile;
    WriteTextFile(path, run.dump(1) + "\n");
    out.written.push_back(path);
  }
  return out;
}

}  // namespace owlcal::reports
