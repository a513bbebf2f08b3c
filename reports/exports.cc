#include "reports/exports.h"

#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include "models/head_kinematics.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

cv::Mat CameraMatrix(const models::CameraIntrinsics& c) {
  cv::Mat m = cv::Mat::eye(3, 3, CV_64F);
  m.at<double>(0, 0) = c.params[0];
  m.at<double>(1, 1) = c.params[1];
  m.at<double>(0, 2) = c.params[2];
  m.at<double>(1, 2) = c.params[3];
  return m;
}

cv::Mat DistMatrix(const models::CameraIntrinsics& c) {
  const auto d = c.Distortion();
  cv::Mat m(1, int(d.size()), CV_64F);
  for (size_t i = 0; i < d.size(); ++i) m.at<double>(0, int(i)) = d[i];
  return m;
}

const models::CameraIntrinsics& Camera(const fitting::CalibrationResult& r, int eye) {
  if (r.cameras[eye]) return *r.cameras[eye];
  if (r.head) return r.head->intrinsics[eye];
  throw std::runtime_error(std::string("export: the result has no ") + models::kEyeNames[eye] + " camera");
}

std::string Num(double v) { return Fmt(v, 12); }

// A C floating literal (always with a '.' or exponent).
std::string FloatLiteral(double v) {
  std::string s = Fmt(v, 6);
  if (s.find_first_of(".e") == std::string::npos) s += ".0";
  return s;
}

std::string List(const cv::Mat& m) {
  std::ostringstream o;
  for (int i = 0; i < m.rows; ++i)
    for (int j = 0; j < m.cols; ++j) o << (i || j ? ", " : "") << Num(m.at<double>(i, j));
  return o.str();
}

void Write(const std::string& path, const std::string& text) { WriteTextFile(path, text); }

}  // namespace

OpenCvStereoFields MakeOpenCvStereoFields(const fitting::CalibrationResult& r) {
  if (!r.stereo) throw std::runtime_error("export: the result has no stereo estimate (right_from_left)");
  OpenCvStereoFields f;
  const auto& cl = Camera(r, models::kLeftEye);
  const auto& cr = Camera(r, models::kRightEye);
  f.M1 = CameraMatrix(cl);
  f.D1 = DistMatrix(cl);
  f.M2 = CameraMatrix(cr);
  f.D2 = DistMatrix(cr);
  f.image_size = cv::Size(cl.width, cl.height);
  const Eigen::Matrix3d R = r.stereo->right_from_left.rotation.toRotationMatrix();
  const Eigen::Vector3d T = r.stereo->right_from_left.translation;
  f.R = cv::Mat(3, 3, CV_64F);
  f.T = cv::Mat(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    f.T.at<double>(i, 0) = T[i];
    for (int j = 0; j < 3; ++j) f.R.at<double>(i, j) = R(i, j);
  }
  cv::Mat tx = (cv::Mat_<double>(3, 3) << 0, -T[2], T[1], T[2], 0, -T[0], -T[1], T[0], 0);
  f.E = tx * f.R;
  f.F = f.M2.inv().t() * f.E * f.M1.inv();
  f.F /= f.F.at<double>(2, 2);
  cv::stereoRectify(f.M1, f.D1, f.M2, f.D2, f.image_size, f.R, f.T, f.R1, f.R2, f.P1, f.P2, f.Q,
                    cv::CALIB_ZERO_DISPARITY, -1);
  return f;
}

void WriteOpenCvYaml(const fitting::CalibrationResult& r, const std::string& path) {
  const OpenCvStereoFields f = MakeOpenCvStereoFields(r);
  const std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  if (!fs.isOpened()) throw std::runtime_error("cannot write OpenCV calibration " + path);
  fs.writeComment("owlcal stereo calibration (OpenCV stereo_calib sample fields). x_right = R x_left + T, T in metres.");
  fs << "image_width" << f.image_size.width << "image_height" << f.image_size.height;
  fs << "M1" << f.M1 << "D1" << f.D1 << "M2" << f.M2 << "D2" << f.D2;
  fs << "R" << f.R << "T" << f.T << "E" << f.E << "F" << f.F;
  fs << "R1" << f.R1 << "R2" << f.R2 << "P1" << f.P1 << "P2" << f.P2 << "Q" << f.Q;
  fs.release();
}

void WriteRosCameraInfo(const fitting::CalibrationResult& r, int eye, const std::string& path) {
  const auto& c = Camera(r, eye);
  cv::Mat K = CameraMatrix(c), D = DistMatrix(c), Rr = cv::Mat::eye(3, 3, CV_64F), P = cv::Mat::zeros(3, 4, CV_64F);
  K.copyTo(P(cv::Rect(0, 0, 3, 3)));
  if (r.stereo) {
    const OpenCvStereoFields f = MakeOpenCvStereoFields(r);
    Rr = eye == models::kLeftEye ? f.R1 : f.R2;
    P = eye == models::kLeftEye ? f.P1 : f.P2;
  }
  std::ostringstream o;
  o << "# ROS camera_info (camera_calibration_parsers YAML), written by owlcal\n"
    << "image_width: " << c.width << "\nimage_height: " << c.height << "\n"
    << "camera_name: owl_" << models::kEyeNames[eye] << "\n"
    << "camera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << List(K) << "]\n"
    << "distortion_model: " << (c.NumDistortion() == 5 ? "plumb_bob" : "rational_polynomial") << "\n"
    << "distortion_coefficients:\n  rows: 1\n  cols: " << D.cols << "\n  data: [" << List(D) << "]\n"
    << "rectification_matrix:\n  rows: 3\n  cols: 3\n  data: [" << List(Rr) << "]\n"
    << "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [" << List(P) << "]\n";
  Write(path, o.str());
}

void WriteKalibrCamchain(const fitting::CalibrationResult& r, const std::string& path) {
  std::ostringstream o;
  o << "# Kalibr camchain, written by owlcal. cam0 = left eye, cam1 = right eye; pinhole-radtan.\n";
  for (int e = 0; e < 2; ++e) {
    const auto& c = Camera(r, e);
    const auto d = c.Distortion();
    o << "cam" << e << ":\n";
    if (e == 1) {
      if (!r.stereo) throw std::runtime_error("export " + path + ": the result has no stereo estimate");
      const Eigen::Matrix4d T = r.stereo->right_from_left.Matrix();
      o << "  T_cn_cnm1:\n";
      for (int i = 0; i < 4; ++i)
        o << "  - [" << Num(T(i, 0)) << ", " << Num(T(i, 1)) << ", " << Num(T(i, 2)) << ", " << Num(T(i, 3)) << "]\n";
    }
    o << "  camera_model: pinhole\n"
      << "  intrinsics: [" << Num(c.params[0]) << ", " << Num(c.params[1]) << ", " << Num(c.params[2]) << ", "
      << Num(c.params[3]) << "]\n"
      << "  distortion_model: radtan\n"
      << "  distortion_coeffs: [" << Num(d[0]) << ", " << Num(d[1]) << ", " << Num(d[2]) << ", " << Num(d[3]) << "]\n";
    bool dropped = false;
    for (size_t i = 4; i < d.size(); ++i) dropped |= d[i] != 0.0;
    if (dropped) o << "  # owlcal: k3 (and k4..k6) dropped: Kalibr's radtan has k1 k2 p1 p2 only\n";
    o << "  resolution: [" << c.width << ", " << c.height << "]\n"
      << "  rostopic: /owl/" << models::kEyeNames[e] << "/image_raw\n"
      << "  cam_overlaps: [" << (1 - e) << "]\n";
  }
  Write(path, o.str());
}

void WriteMrcalCameraModel(const fitting::CalibrationResult& r, int eye, const std::string& path) {
  const auto& c = Camera(r, eye);
  double rt[6] = {0, 0, 0, 0, 0, 0};
  if (eye == models::kRightEye) {
    if (!r.stereo) throw std::runtime_error("export " + path + ": the result has no stereo estimate");
    const Eigen::AngleAxisd aa(r.stereo->right_from_left.rotation);
    const Eigen::Vector3d rv = aa.axis() * aa.angle();
    for (int i = 0; i < 3; ++i) {
      rt[i] = rv[i];
      rt[3 + i] = r.stereo->right_from_left.translation[i];
    }
  }
  std::ostringstream o;
  o << "# generated by owlcal: the " << models::kEyeNames[eye] << " eye; reference frame = left camera\n"
    << "{\n    'lensmodel':  '" << (c.NumDistortion() == 5 ? "LENSMODEL_OPENCV5" : "LENSMODEL_OPENCV8") << "',\n"
    << "    # fx, fy, cx, cy, distortion (OpenCV order)\n    'intrinsics': [ ";
  for (size_t i = 0; i < c.params.size(); ++i) o << (i ? ", " : "") << Num(c.params[i]);
  o << " ],\n    # rt_cam_ref: rotation vector [rad], translation [m]\n    'extrinsics': [ ";
  for (int i = 0; i < 6; ++i) o << (i ? ", " : "") << Num(rt[i]);
  o << " ],\n    'imagersize': [ " << c.width << ", " << c.height << " ],\n}\n";
  Write(path, o.str());
}

std::string OwlPwmHeaderText(const fitting::CalibrationResult& r,
                             const models::RobotConfig& config,
                             const fitting::LimitsEvaluation* limits) {
  int lo[models::kNumServos], hi[models::kNumServos], centre[models::kNumServos];
  std::string centre_note[models::kNumServos], limit_note[models::kNumServos];
  for (int s = 0; s < models::kNumServos; ++s) {
    lo[s] = config.servos[s].min_us;
    hi[s] = config.servos[s].max_us;
    limit_note[s] = "configured";
    if (limits) {
      for (const auto& l : limits->servos) {
        if (l.servo != s) continue;
        lo[s] = l.recommended_min_us;
        hi[s] = l.recommended_max_us;
        limit_note[s] = std::string("measured: low ") + (l.measured_min_us ? fitting::LimitCauseName(l.min_cause) : "not measured") +
                        ", high " + (l.measured_max_us ? fitting::LimitCauseName(l.max_cause) : "not measured");
      }
    }
    centre[s] = config.servos[s].centre_us;
    centre_note[s] = "configured";
    const fitting::Parameter* p = r.Find(std::string("servo.") + models::kServoNames[s] + ".centre_us");
    if (p && p->determined && std::isfinite(p->value)) {
      centre[s] = int(std::lround(p->value));
      centre_note[s] = "fitted " + Fmt(p->value, 6) + " +- " + Fmt(p->sigma, 2) + " us";
    }
  }
  // The guide names ends by direction: R/L = the robot's right/left (pan), T/B = top/bottom.
  auto end = [&](int s, bool positive_angle) { return (config.servos[s].direction > 0) == positive_angle ? hi[s] : lo[s]; };
  using models::kLx; using models::kLy; using models::kNeck; using models::kRx; using models::kRy;
  std::ostringstream o;
  o << "// owl-pwm.h: servo limits and centres of this Owl, measured by owlcal " << r.software_version << ".\n"
    << "// Course naming (Owl user guide, code snippet 5). Include it instead of the hand-set values.\n"
    << "#pragma once\n\n// OWL eye ranges\n";
  for (int s = 0; s < models::kNumServos; ++s)
    o << "// " << models::kServoNames[s] << ": limits " << limit_note[s] << "; centre " << centre_note[s] << "\n";
  o << "int RyB = " << end(kRy, false) << "; // (bottom) to\n"
    << "int RyT = " << end(kRy, true) << "; // (top)\n"
    << "int RxR = " << end(kRx, true) << "; // (right) to\n"
    << "int RxL = " << end(kRx, false) << "; // (left)\n"
    << "int LyB = " << end(kLy, false) << "; // (bottom) to\n"
    << "int LyT = " << end(kLy, true) << "; // (top)\n"
    << "int LxR = " << end(kLx, true) << "; // (right) to\n"
    << "int LxL = " << end(kLx, false) << "; // (left)\n"
    << "int NeckR = " << end(kNeck, true) << ";\n"
    << "int NeckL = " << end(kNeck, false) << ";\n"
    << "int RxC = " << centre[kRx] << ";\n"
    << "int RyC = " << centre[kRy] << ";\n"
    << "int LxC = " << centre[kLx] << ";\n"
    << "int LyC = " << centre[kLy] << ";\n"
    << "int NeckC = " << centre[kNeck] << ";\n"
    << "int Ry, Rx, Ly, Lx, Neck; // calculate values for position\n"
    << "int RyRange = RyT - RyB;\n"
    << "int RxRange = RxR - RxL;\n"
    << "int LyRange = LyT - LyB; // reflected so negative\n"
    << "int LxRange = LxR - LxL;\n"
    << "int NeckRange = NeckL - NeckR;\n\n"
    << "// Calibrated scales [deg per us] (the course's nominal value is 0.113) and IPD [mm].\n";
  for (int s = 0; s < models::kNumServos; ++s) {
    const fitting::Parameter* p = r.Find(std::string("servo.") + models::kServoNames[s] + ".deg_per_us");
    std::string name = models::kServoNames[s];
    for (auto& ch : name) ch = std::toupper(ch);
    const double v = p && p->determined && std::isfinite(p->value) ? p->value : config.servos[s].nominal_deg_per_us;
    o << "#define OWLCAL_" << name << "_DEG_PER_US " << FloatLiteral(v) << (p && p->determined ? "" : "  // nominal: not determined") << "\n";
  }
  const fitting::Parameter* ipd = r.Find("head.ipd_mm");
  const double ipd_mm = ipd && ipd->determined && std::isfinite(ipd->value) ? ipd->value : config.ipd_m * 1000;
  o << "#define OWLCAL_IPD_MM " << FloatLiteral(ipd_mm) << (ipd && ipd->determined ? "" : "  // design value: not determined") << "\n";
  return o.str();
}

void WriteOwlPwmHeader(const fitting::CalibrationResult& r,
                       const models::RobotConfig& config,
                       const fitting::LimitsEvaluation* limits,
                       const std::string& path) {
  Write(path, OwlPwmHeaderText(r, config, limits));
}

std::vector<std::string> WriteAllExports(const fitting::CalibrationResult& r,
                                         const models::RobotConfig& config,
                                         const fitting::LimitsEvaluation* limits,
                                         const std::string& dir,
                                         std::vector<std::string>* skipped) {
  std::vector<std::string> written;
  std::filesystem::create_directories(dir);
  auto attempt = [&](const std::string& path, auto&& fn) {
    try {
      fn(path);
      written.push_back(path);
    } catch (const std::exception& e) {
      if (skipped) skipped->push_back(path + ": " + e.what());
    }
  };
  for (int e = 0; e < 2; ++e) {
    attempt(dir + "/ros_" + models::kEyeNames[e] + ".yaml", [&](const std::string& p) { WriteRosCameraInfo(r, e, p); });
    attempt(dir + "/" + models::kEyeNames[e] + ".cameramodel", [&](const std::string& p) { WriteMrcalCameraModel(r, e, p); });
  }
  attempt(dir + "/kalibr_camchain.yaml", [&](const std::string& p) { WriteKalibrCamchain(r, p); });
  attempt(dir + "/owl-pwm.h", [&](const std::string& p) { WriteOwlPwmHeader(r, config, limits, p); });
  return written;
}

}  // namespace owlcal::reports
