// Every export loaded with its neighbour's own parser: OpenCV's cv::FileStorage for
// calibration.yaml and the course's xml (in mm), yaml-cpp (what ROS's
// camera_calibration_parsers and Kalibr's YAML readers parse) for ROS and Kalibr, mrcal's own
// Python module for the .cameramodel (when python3-mrcal is installed), and the C and C++
// compilers found at test time for owl-pwm.h (two translation units each).
#include "reports/exports.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include "fitting/calibration_folder.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/radtan_refit.h"
#include "models/head_model.h"
#include "owlcal_version.h"
#include "reports/report_data.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

std::string TempDir(const std::string& name) {
  const std::string dir = (std::filesystem::temp_directory_path() / ("owlcal_exports_test_" + name)).string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

std::string Slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

std::string Shell(const std::string& cmd, int* status) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[256];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), p)) > 0) out.append(buf, n);
  *status = pclose(p);
  return out;
}

// The first of the programs that runs (`NAME --version`), or "".
std::string FindProgram(std::initializer_list<const char*> names) {
  for (const char* n : names) {
    int st = 0;
    Shell(std::string("command -v ") + n + " >/dev/null 2>&1", &st);
    if (st == 0) return n;
  }
  return "";
}

cv::Mat ReadMat(const cv::FileStorage& fs, const char* name) {
  cv::Mat m;
  fs[name] >> m;
  return m;
}

ReportData StereoData() {
  ReportData d;
  fitting::CalibrationResult& r = d.result;
  r.software_version = "test";
  models::CameraIntrinsics l, rr;
  l.params = {582.0, 581.0, 322.0, 238.0, -0.12, 0.08, 0.001, -0.0005, -0.01};
  rr.params = {579.0, 580.0, 317.0, 243.0, -0.10, 0.05, -0.0007, 0.0004, 0.0};
  r.cameras[0] = l;
  r.cameras[1] = rr;
  fitting::StereoEstimate s;
  s.right_from_left.rotation = Eigen::AngleAxisd(0.02, Eigen::Vector3d(0.1, 1, 0.05).normalized());
  s.right_from_left.translation = Eigen::Vector3d(-0.0648, 0.0007, 0.0012);
  r.stereo = s;
  // Parameter sigmas (the mrcal region's uncertainty) and corner residuals over the middle of
  // the image only: the valid region must leave out the uncovered border.
  const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
  const double sig[] = {0.05, 0.05, 0.05, 0.05, 1e-4, 1e-4, 1e-5, 1e-5, 1e-4};
  for (int e = 0; e < 2; ++e)
    for (int i = 0; i < 9; ++i)
      r.Set({std::string(e ? "right." : "left.") + names[i], r.cameras[e]->params[i], sig[i], "", {}, true, ""});
  unsigned seed = 7;
  auto noise = [&] {
    seed = seed * 1103515245u + 12345u;
    return ((seed >> 16) % 2001) / 1000.0 - 1.0;
  };
  for (int e = 0; e < 2; ++e)
    for (double y = 100; y <= 380; y += 4)
      for (double x = 140; x <= 500; x += 4) d.residuals.push_back({e, 0, x, y, 0.1 * noise(), 0.1 * noise()});
  return d;
}

TEST(Exports, OpenCvYamlInMetresAndCourseXmlInMillimetres) {
  const ReportData d = StereoData();
  const std::string dir = TempDir("opencv");
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  ASSERT_TRUE(std::filesystem::exists(dir + "/calibration.yaml"));
  cv::FileStorage fs(dir + "/calibration.yaml", cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  const cv::Mat M1 = ReadMat(fs, "M1"), D1 = ReadMat(fs, "D1"), M2 = ReadMat(fs, "M2"), D2 = ReadMat(fs, "D2");
  const cv::Mat R = ReadMat(fs, "R"), T = ReadMat(fs, "T"), R1 = ReadMat(fs, "R1"), R2 = ReadMat(fs, "R2");
  const cv::Mat P1 = ReadMat(fs, "P1"), P2 = ReadMat(fs, "P2"), Q = ReadMat(fs, "Q"), E = ReadMat(fs, "E"),
                F = ReadMat(fs, "F");
  EXPECT_EQ(int(fs["image_width"]), 640);
  EXPECT_EQ(std::string(fs["length_unit"]), "m");
  EXPECT_DOUBLE_EQ(M1.at<double>(0, 0), 582.0);
  EXPECT_DOUBLE_EQ(D1.at<double>(0, 4), -0.01);
  EXPECT_DOUBLE_EQ(T.at<double>(0, 0), -0.0648);
  EXPECT_NE(Slurp(dir + "/calibration.yaml").find("in m."), std::string::npos);
  // Recomputing the rectification from the loaded calibration gives the stored one.
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(M1, D1, M2, D2, cv::Size(640, 480), R, T, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, -1);
  EXPECT_LT(cv::norm(r1 - R1), 1e-9);
  EXPECT_LT(cv::norm(p2 - P2), 1e-6);
  // It rectifies, and Q maps disparity back to depth; the epipolar constraint holds.
  for (const cv::Point3d X : {cv::Point3d(0.1, -0.05, 0.8), cv::Point3d(-0.2, 0.1, 1.5), cv::Point3d(0.0, 0.15, 0.4)}) {
    std::vector<cv::Point2d> pl, pr, ul, ur;
    cv::Mat rvec;
    cv::Rodrigues(R, rvec);
    cv::projectPoints(
        std::vector<cv::Point3d>{X}, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F), M1, D1, pl);
    cv::projectPoints(std::vector<cv::Point3d>{X}, rvec, T, M2, D2, pr);
    cv::undistortPoints(pl, ul, M1, D1, R1, P1);
    cv::undistortPoints(pr, ur, M2, D2, R2, P2);
    EXPECT_NEAR(ul[0].y, ur[0].y, 1e-3) << X;
    cv::Mat v = (cv::Mat_<double>(4, 1) << ul[0].x, ul[0].y, ul[0].x - ur[0].x, 1.0);
    cv::Mat w = Q * v;
    const cv::Mat Xr = R1 * (cv::Mat_<double>(3, 1) << X.x, X.y, X.z);
    EXPECT_NEAR(w.at<double>(2) / w.at<double>(3), Xr.at<double>(2), 1e-6 * X.z + 1e-9) << X;
    const cv::Mat xl = (cv::Mat_<double>(3, 1) << X.x, X.y, X.z), xr = R * xl + T;
    EXPECT_NEAR(cv::Mat(xr.t() * E * xl).at<double>(0), 0.0, 1e-12);
  }

  // The course's files: the same calibration in millimetres, saying so.
  cv::FileStorage fi(dir + "/intrinsics.xml", cv::FileStorage::READ),
      fe(dir + "/extrinsics.xml", cv::FileStorage::READ);
  ASSERT_TRUE(fi.isOpened());
  ASSERT_TRUE(fe.isOpened());
  EXPECT_EQ(cv::norm(ReadMat(fi, "M1") - M1), 0);
  EXPECT_EQ(cv::norm(ReadMat(fi, "D2") - D2), 0);
  EXPECT_TRUE(ReadMat(fi, "T").empty());
  EXPECT_EQ(std::string(fe["length_unit"]), "mm");
  EXPECT_NE(Slurp(dir + "/extrinsics.xml").find("in mm."), std::string::npos);
  const cv::Mat Tmm = ReadMat(fe, "T"), Qmm = ReadMat(fe, "Q"), P2mm = ReadMat(fe, "P2");
  EXPECT_NEAR(Tmm.at<double>(0), -64.8, 1e-12);
  EXPECT_NEAR(Qmm.at<double>(3, 2), Q.at<double>(3, 2) / 1000, 1e-15);
  EXPECT_NEAR(P2mm.at<double>(0, 3), 1000 * P2.at<double>(0, 3), 1e-9);
  EXPECT_LT(cv::norm(ReadMat(fe, "R1") - R1), 1e-15);
  // The course's own depth formula Z = f * B / d in mm: Q(3,2) = -1/Tx' [1/mm], Tx' the baseline
  // along the rectified x axis (-|T|).
  EXPECT_NEAR(-1.0 / Qmm.at<double>(3, 2), -cv::norm(Tmm), 1e-9);
}

TEST(Exports, CourseXmlHasTheFieldsAndUnitsOfTheCourseReference) {
  // The course's reference files (kit2020, mm) and ours hold the same fields, shapes and scale.
  const std::string ref = std::string(OWLCAL_SOURCE_DIR) + "/data/owl-real/kit2020-chessboard/reference/";
  const std::string dir = TempDir("course");
  WriteCalibrationFiles(StereoData(), dir);
  for (const char* file : {"intrinsics.xml", "extrinsics.xml"}) {
    cv::FileStorage a(ref + file, cv::FileStorage::READ), b(dir + "/" + file, cv::FileStorage::READ);
    ASSERT_TRUE(a.isOpened()) << ref << file;
    ASSERT_TRUE(b.isOpened());
    for (const char* f : {"M1", "D1", "M2", "D2", "R", "T", "R1", "R2", "P1", "P2", "Q"}) {
      const cv::Mat ma = ReadMat(a, f), mb = ReadMat(b, f);
      if (ma.empty()) continue;
      ASSERT_FALSE(mb.empty()) << file << " lacks " << f;
      if (f[0] != 'D') {
        EXPECT_EQ(ma.size(), mb.size()) << f;
      }
    }
  }
  cv::FileStorage a(ref + "extrinsics.xml", cv::FileStorage::READ), b(dir + "/extrinsics.xml", cv::FileStorage::READ);
  const double ta = ReadMat(a, "T").at<double>(0), tb = ReadMat(b, "T").at<double>(0);
  EXPECT_NEAR(tb / ta, 1.0, 0.05) << "course T " << ta << " mm, ours " << tb;
  EXPECT_NEAR(ReadMat(b, "Q").at<double>(3, 2) / ReadMat(a, "Q").at<double>(3, 2), 1.0, 0.05);
}

TEST(Exports, RosCameraInfoUsesRosAlphaZeroAndSaysSo) {
  const ReportData d = StereoData();
  const std::string dir = TempDir("ros");
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  const fitting::CalibrationResult& r = d.result;
  cv::Mat K1 = (cv::Mat_<double>(3, 3) << 582, 0, 322, 0, 581, 238, 0, 0, 1),
          K2 = (cv::Mat_<double>(3, 3) << 579, 0, 317, 0, 580, 243, 0, 0, 1);
  cv::Mat D1(r.cameras[0]->Distortion(), true), D2(r.cameras[1]->Distortion(), true), Rm, Tm, R1, R2, P1, P2, Q;
  cv::eigen2cv(Eigen::Matrix3d(r.stereo->right_from_left.rotation.toRotationMatrix()), Rm);
  cv::eigen2cv(Eigen::Vector3d(r.stereo->right_from_left.translation), Tm);
  cv::stereoRectify(
      K1, D1.t(), K2, D2.t(), cv::Size(640, 480), Rm, Tm, R1, R2, P1, P2, Q, cv::CALIB_ZERO_DISPARITY, 0.0);
  for (int e = 0; e < 2; ++e) {
    const std::string path = dir + "/exports/ros_" + std::string(e ? "right" : "left") + ".yaml";
    const std::string text = Slurp(path);
    EXPECT_NE(text.find("alpha = 0"), std::string::npos) << text;
    const YAML::Node n = YAML::LoadFile(path);
    EXPECT_EQ(n["image_width"].as<int>(), 640);
    EXPECT_EQ(n["distortion_model"].as<std::string>(), "plumb_bob");
    EXPECT_EQ(n["distortion_coefficients"]["data"].size(), 5u);
    EXPECT_EQ(n["camera_matrix"]["data"][0].as<double>(), e ? 579.0 : 582.0);
    const auto P = n["projection_matrix"]["data"].as<std::vector<double>>();
    ASSERT_EQ(P.size(), 12u);
    const cv::Mat& ref = e ? P2 : P1;
    for (int i = 0; i < 12; ++i) EXPECT_NEAR(P[i], ref.at<double>(i / 4, i % 4), 1e-9 * (1 + std::abs(P[i]))) << i;
  }
}

TEST(Exports, KalibrCamchainRefitsRadtanAndReportsItsError) {
  const ReportData d = StereoData();
  const std::string dir = TempDir("kalibr");
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  const std::string path = dir + "/exports/kalibr_camchain.yaml";
  const YAML::Node n = YAML::LoadFile(path);
  for (int e = 0; e < 2; ++e) {
    const YAML::Node c = n[e ? "cam1" : "cam0"];
    ASSERT_TRUE(c) << Slurp(path);
    EXPECT_EQ(c["camera_model"].as<std::string>(), "pinhole");
    EXPECT_EQ(c["distortion_model"].as<std::string>(), "radtan");
    const auto k = c["distortion_coeffs"].as<std::vector<double>>();
    ASSERT_EQ(k.size(), 4u);
    EXPECT_EQ(c["intrinsics"].as<std::vector<double>>()[0], e ? 579.0 : 582.0);
    EXPECT_EQ(c["resolution"].as<std::vector<int>>()[0], 640);
    // Kalibr's radtan projection with these numbers against the fitted model, over the image.
    const models::CameraIntrinsics& orig = *d.result.cameras[e];
    models::CameraIntrinsics radtan = orig;
    radtan.params = {orig.params[0], orig.params[1], orig.params[2], orig.params[3], k[0], k[1], k[2], k[3], 0.0};
    double worst = 0;
    for (double v = 0; v <= 479; v += 479.0 / 12)
      for (double u = 0; u <= 639; u += 639.0 / 16) {
        double pix[2] = {u, v}, ray[3], q[2] = {0, 0};
        ASSERT_TRUE(orig.Unproject(pix, ray));
        radtan.Project(ray, q);
        worst = std::max(worst, std::hypot(q[0] - u, q[1] - v));
      }
    const fitting::RadtanRefit fit = fitting::FitRadtan4(orig);
    EXPECT_LE(worst, fit.max_error_px + 1e-9);
    if (e == 0) {
      // k3 = -0.01: not representable, refitted, and the file says how well.
      EXPECT_GT(fit.max_error_px, 0.0);
      EXPECT_NE(Slurp(path).find("max error " + Fmt(fit.max_error_px, 3) + " px"), std::string::npos) << Slurp(path);
      std::printf("radtan4 refit of k3 = -0.01: max %.3f px, RMS %.3f px (dropping k3: see below)\n",
                  fit.max_error_px,
                  fit.rms_error_px);
    } else {
      EXPECT_TRUE(fit.exact);  // k3 = 0: radtan holds it exactly
      EXPECT_LT(worst, 1e-6);
    }
  }
  const auto T = n["cam1"]["T_cn_cnm1"].as<std::vector<std::vector<double>>>();
  ASSERT_EQ(T.size(), 4u);
  EXPECT_DOUBLE_EQ(T[0][3], -0.0648);
  // Dropping k3 instead of refitting would be worse.
  models::CameraIntrinsics dropped = *d.result.cameras[0];
  dropped.params[8] = 0;
  double pix[2] = {0, 0}, ray[3], q[2] = {0, 0};
  d.result.cameras[0]->Unproject(pix, ray);
  dropped.Project(ray, q);
  EXPECT_GT(std::hypot(q[0], q[1]), fitting::FitRadtan4(*d.result.cameras[0]).max_error_px);
}

TEST(Exports, MrcalModelHasAValidIntrinsicsRegionAndLoadsInMrcal) {
  const ReportData d = StereoData();
  const std::string dir = TempDir("mrcal");
  WriteCalibrationFiles(d, dir);
  const std::string path = dir + "/exports/right.cameramodel";
  const std::string text = Slurp(path);
  EXPECT_NE(text.find("'lensmodel':  'LENSMODEL_OPENCV5'"), std::string::npos);
  EXPECT_NE(text.find("'valid_intrinsics_region': ["), std::string::npos) << text;
  // The region follows the residuals: inside the covered middle, not the uncovered corners.
  std::vector<cv::Point2f> contour;
  std::istringstream in(text.substr(text.find("'valid_intrinsics_region'")));
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line) && line.find('[') != std::string::npos) {
    float x, y;
    if (std::sscanf(line.c_str(), " [ %f, %f ]", &x, &y) == 2) contour.emplace_back(x, y);
  }
  ASSERT_GE(contour.size(), 4u);
  EXPECT_EQ(contour.front(), contour.back());
  EXPECT_GT(cv::pointPolygonTest(contour, cv::Point2f(320, 240), false), 0);
  EXPECT_LT(cv::pointPolygonTest(contour, cv::Point2f(10, 10), false), 0);
  EXPECT_LT(cv::pointPolygonTest(contour, cv::Point2f(630, 470), false), 0);

  // Loaded by mrcal itself: projections agree with owlcal's model, and mrcal sees the region.
  std::string py;
  for (const char* p : {"python3", "/usr/bin/python3"}) {
    int st = 0;
    Shell(std::string(p) + " -c 'import mrcal' >/dev/null 2>&1", &st);
    if (st == 0) {
      py = p;
      break;
    }
  }
  if (py.empty())
    GTEST_SKIP() << "python3-mrcal not importable: mrcal projection check skipped (apt install python3-mrcal)";
  const std::string script = dir + "/check.py";
  std::ofstream(script) << "import mrcal, numpy as np\n"
                           "m = mrcal.cameramodel('"
                        << path
                        << "')\n"
                           "p = np.array([[0.1, -0.05, 1.0], [-0.3, 0.2, 0.9], [0.25, 0.18, 0.5]])\n"
                           "q = mrcal.project(p, *m.intrinsics())\n"
                           "print(m.intrinsics()[0])\n"
                           "for r in q: print('%.9f %.9f' % (r[0], r[1]))\n"
                           "print(len(m.valid_intrinsics_region()))\n"
                           "print(' '.join('%.9f' % x for x in m.extrinsics_rt_fromref()))\n";
  int st = 0;
  const std::string out = Shell(py + " " + script + " 2>&1", &st);
  ASSERT_EQ(st, 0) << out;
  std::istringstream o(out);
  std::string model;
  o >> model;
  EXPECT_EQ(model, "LENSMODEL_OPENCV5");
  const double pts[3][3] = {{0.1, -0.05, 1.0}, {-0.3, 0.2, 0.9}, {0.25, 0.18, 0.5}};
  for (const auto& p : pts) {
    double u, v, q[2];
    o >> u >> v;
    d.result.cameras[1]->Project(p, q);
    EXPECT_NEAR(u, q[0], 1e-6);
    EXPECT_NEAR(v, q[1], 1e-6);
  }
  size_t n = 0;
  o >> n;
  EXPECT_EQ(n, contour.size());
  double rt[6];
  for (double& x : rt) o >> x;
  EXPECT_NEAR(rt[3], -0.0648, 1e-9);
}

TEST(Exports, OwlPwmHeaderCompilesAsCAndCppFromTwoFilesAndInvertsWithClamping) {
  ReportData d = StereoData();
  const models::RobotConfig cfg = models::DefaultRobotConfig();
  d.config = cfg;
  models::HeadModel h = models::NominalHeadModel(cfg);
  h.servo_params[models::kRx] = {1538.6, 0.1105, 0.4, -0.2, 1.5};
  h.servo_params[models::kLy] = {1575.0, 0.1150, -0.3, 0.5, 1.0};
  h.servo_params[models::kNeck] = {1530.0, 0.1080, 1.2, -3.4, 2.0};
  d.result.head = h;
  for (int s = 0; s < models::kNumServos; ++s) {
    const std::string n = std::string("servo.") + models::kServoNames[s];
    d.result.Set({n + ".deg_per_us", h.servo_params[s][1], 1e-4, "deg/us", {}, true, ""});
    if (s == models::kRx) d.result.Set({n + ".centre_us", 1538.6, 0.4, "us", {}, true, ""});
  }
  d.limits = evaluation::EvaluateLimits(cfg,
                                        {{models::kRx, false, 1230, evaluation::LimitCause::kEndStop},
                                         {models::kLy, true, 1950, evaluation::LimitCause::kSocketRim}},
                                        nullptr,
                                        10);
  const std::string dir = TempDir("owlpwm");
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  ASSERT_TRUE(std::filesystem::exists(dir + "/exports/owl-pwm.h"));
  std::filesystem::copy_file(dir + "/exports/owl-pwm.h", dir + "/owl-pwm.h");
  // Two translation units include the header; main prints the course values, the maps and the
  // inverse (with angles beyond the limits: clamped).
  const char* other = "#include \"owl-pwm.h\"\nint owl_other(void) { return RxC + OwlDegToPwm(&OwlNeck, 5.0); }\n";
  const char* main_src =
      "#include <stdio.h>\n#include \"owl-pwm.h\"\nint owl_other(void);\n"
      "int main(void) {\n"
      "  const OwlServoMap* m[5] = {&OwlRx, &OwlRy, &OwlLx, &OwlLy, &OwlNeck};\n"
      "  const double us[3] = {1250.0, 1545.0, 1800.0};\n"
      "  const double deg[4] = {-100.0, -10.0, 12.5, 100.0};\n"
      "  int s, i;\n"
      "  printf(\"%d %d %d %d %d %d %d %d %d %d %d %d %d %d %d %d %.3f\\n\", RyB, RyT, RxR, RxL, LyB, LyT, LxR, LxL,\n"
      "         NeckR, NeckL, RxC, RyC, LxC, LyC, NeckC, LyRange, OwlIpdMm);\n"
      "  for (s = 0; s < 5; ++s) {\n"
      "    printf(\"%s %d %d\", m[s]->name, m[s]->direction, m[s]->fitted);\n"
      "    for (i = 0; i < 3; ++i) printf(\" %.9f\", OwlPwmToDeg(m[s], us[i]));\n"
      "    for (i = 0; i < 4; ++i) printf(\" %d\", OwlDegToPwm(m[s], deg[i]));\n"
      "    printf(\"\\n\");\n"
      "  }\n"
      "  printf(\"%d\\n\", owl_other());\n"
      "  return 0;\n}\n";
  std::ofstream(dir + "/other.c") << other;
  std::ofstream(dir + "/main.c") << main_src;
  std::ofstream(dir + "/other.cpp") << other;
  std::ofstream(dir + "/main.cpp") << main_src;
  const std::string c = FindProgram({"cc", "gcc", "clang"}), cxx = FindProgram({"c++", "g++", "clang++"});
  if (c.empty() && cxx.empty())
    GTEST_SKIP() << "no C or C++ compiler on PATH (cc, gcc, clang, c++, g++, clang++): owl-pwm.h not compiled";
  std::vector<std::string> outputs;
  for (const auto& [compiler, flags, ext] : {std::tuple{c, std::string("-std=c99"), std::string(".c")},
                                             std::tuple{cxx, std::string("-std=c++11"), std::string(".cpp")}}) {
    if (compiler.empty()) {
      std::printf("no %s compiler found: owl-pwm.h not compiled as %s\n", ext == ".c" ? "C" : "C++", ext.c_str());
      continue;
    }
    int st = 0;
    const std::string exe = dir + "/prog" + (ext == ".c" ? "_c" : "_cpp");
    const std::string log =
        Shell("cd " + dir + " && " + compiler + " " + flags + " -Wall -Wextra -pedantic -Werror -o " + exe + " main" +
                  ext + " other" + ext + " 2>&1",
              &st);
    ASSERT_EQ(st, 0) << compiler << " " << flags << ":\n" << log << "\n" << Slurp(dir + "/owl-pwm.h");
    outputs.push_back(Shell(exe, &st));
    ASSERT_EQ(st, 0);
  }
  ASSERT_FALSE(outputs.empty());
  if (outputs.size() == 2) {
    EXPECT_EQ(outputs[0], outputs[1]);
  }
  std::istringstream o(outputs[0]);
  std::string first;
  std::getline(o, first);
  // Guide values except: Rx low end-stop at 1230 (+10 margin +5 for the search's error), Ly high
  // (bottom) rim at 1950, fitted Rx centre 1539.
  EXPECT_EQ(first, "1120 2000 1890 1245 1935 1180 1850 1180 1100 1950 1539 1530 1545 1580 1530 -755 65.000");
  const double us[3] = {1250.0, 1545.0, 1800.0}, deg[4] = {-100.0, -10.0, 12.5, 100.0};
  for (int s = 0; s < models::kNumServos; ++s) {
    std::string name;
    int dir_, fitted;
    o >> name >> dir_ >> fitted;
    EXPECT_EQ(name, models::kServoNames[s]);
    EXPECT_EQ(dir_, cfg.servos[s].direction) << name;  // Ly and Neck run backwards
    EXPECT_EQ(fitted, 1);
    // The fitted map, nonlinear terms included (the middle of the backlash band).
    for (double u : us) {
      double a;
      o >> a;
      EXPECT_NEAR(a, h.ServoAngle(s, u) * 180 / M_PI, 1e-7) << name << " at " << u;
    }
    const auto& lim = d.limits->servos[s];
    for (double a : deg) {
      int u;
      o >> u;
      EXPECT_GE(u, lim.recommended_min_us) << name;
      EXPECT_LE(u, lim.recommended_max_us) << name;
      const double exact = h.ServoPulse(s, a * M_PI / 180);
      if (std::isfinite(exact) && exact >= lim.recommended_min_us && exact <= lim.recommended_max_us) {
        EXPECT_LE(std::abs(u - exact), 0.5 + 1e-6) << name << " " << a << " deg";
      } else {
        EXPECT_TRUE(u == lim.recommended_min_us || u == lim.recommended_max_us) << name << " " << a << " deg -> " << u;
      }
    }
  }
}

TEST(Exports, WhatCannotBeWrittenIsSkippedWithAReason) {
  ReportData d;
  d.result.cameras[0] = models::CameraIntrinsics();
  const std::string dir = TempDir("skipped");
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  // One camera, no stereo, no servo maps: the left eye's monocular files only.
  ASSERT_EQ(ex.written.size(), 2u);
  EXPECT_EQ(ex.written[0], dir + "/exports/ros_left.yaml");
  EXPECT_EQ(ex.written[1], dir + "/exports/left.cameramodel");
  EXPECT_NE(Slurp(ex.written[0]).find("monocular"), std::string::npos);
  std::string all;
  for (const auto& s : ex.skipped) all += s + "\n";
  for (const char* f : {"calibration.yaml: ",
                        "intrinsics.xml: ",
                        "ros_right.yaml: ",
                        "right.cameramodel: ",
                        "kalibr_camchain.yaml: ",
                        "owl-pwm.h: "})
    EXPECT_NE(all.find(f), std::string::npos) << f << " not skipped:\n" << all;
  EXPECT_NE(all.find("no right camera"), std::string::npos) << all;
  EXPECT_NE(all.find("no servo map was fitted"), std::string::npos) << all;
}

// Regression: `report` on a results.json whose fx was 1e308 rewrote calibration.yaml and the ROS
// and Kalibr exports with it. Nothing is written from a value that is not finite and plausible,
// and an earlier good calibration.yaml is left as it was.
TEST(Exports, NothingIsExportedFromAnImplausibleOrNonFiniteValue) {
  const std::string dir = TempDir("implausible");
  ASSERT_FALSE(WriteCalibrationFiles(StereoData(), dir).written.empty());
  const std::string good = Slurp(dir + "/calibration.yaml");
  ASSERT_FALSE(good.empty());
  struct Case {
    int param;
    double value;
    const char* says;
  };
  for (const Case& c : {Case{0, 1e308, "left camera fx = 1e+308 px is not plausible"},
                        Case{1, std::nan(""), "left camera parameter fy is not finite"},
                        Case{2, -5000, "left camera principal point"},
                        Case{4, 1e9, "left camera distortion k1"}}) {
    ReportData d = StereoData();
    d.result.cameras[0]->params[c.param] = c.value;
    EXPECT_NE(ImplausibleExportValue(d.result).find(c.says), std::string::npos) << ImplausibleExportValue(d.result);
    try {
      WriteCalibrationFiles(d, dir);
      ADD_FAILURE() << "exported with parameter " << c.param << " = " << c.value;
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(dir + "/results.json: " + c.says), std::string::npos) << e.what();
    }
    EXPECT_EQ(Slurp(dir + "/calibration.yaml"), good);
  }
  ReportData far = StereoData();
  far.result.stereo->right_from_left.translation.x() = 1e300;
  EXPECT_THROW(WriteCalibrationFiles(far, dir), std::runtime_error);
  EXPECT_EQ(Slurp(dir + "/calibration.yaml"), good);
}

// An output folder never mixes runs: every export carries the result's run id (the OpenCV files
// an owlcal_run_id node, the rest through exports/owlcal_run.json), and an export an earlier
// writing left (here owl-pwm.h, which this result has no servo maps for) does not survive.
TEST(Exports, TheExportsCarryTheRunIdAndNoEarlierExportSurvives) {
  const std::string dir = TempDir("run_id");
  std::filesystem::create_directories(dir + "/exports");
  for (const char* stale : {"/exports/owl-pwm.h", "/exports/notes.txt"}) std::ofstream(dir + stale) << "stale\n";
  ReportData d = StereoData();
  d.result.run_id = "20250101T000000Z-0000abcd";
  WriteReportData(d, dir);
  const ExportSet ex = WriteCalibrationFiles(d, dir);
  EXPECT_FALSE(std::filesystem::exists(dir + "/exports/owl-pwm.h"));
  EXPECT_FALSE(std::filesystem::exists(dir + "/exports/notes.txt"));
  for (const char* f : {"/calibration.yaml", "/intrinsics.xml", "/extrinsics.xml"})
    EXPECT_EQ(fitting::ReadOpenCvCalibration(dir + f).run_id, d.result.run_id) << f;
  const nlohmann::json run = nlohmann::json::parse(Slurp(dir + "/exports/owlcal_run.json"));
  EXPECT_EQ(run.at("run_id"), d.result.run_id);
  std::vector<std::string> listed = run.at("files").get<std::vector<std::string>>(), present;
  for (const auto& e : std::filesystem::directory_iterator(dir + "/exports"))
    if (e.path().filename() != "owlcal_run.json") present.push_back(e.path().filename().string());
  std::sort(listed.begin(), listed.end());
  std::sort(present.begin(), present.end());
  EXPECT_EQ(listed, present);
  EXPECT_GE(listed.size(), 5u);
  EXPECT_EQ(nlohmann::json::parse(Slurp(dir + "/evaluation.json")).at("run_id"), d.result.run_id);
  EXPECT_EQ(fitting::MixedRunsError(dir), "");
  EXPECT_NO_THROW(ReadReportData(dir));
  // evaluation.json of another run: `owlcal report` would draw one run's evaluation next to another's
  // result.
  ReportData other = d;
  other.result.run_id = "20250101T000001Z-0000beef";
  WriteTextFile(dir + "/evaluation.json", EvaluationToJson(other).dump() + "\n");
  try {
    ReadReportData(dir);
    ADD_FAILURE() << "read a folder of two runs";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("run 20250101T000001Z-0000beef: evaluation.json"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace owlcal::reports
