#include "reports/exports.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "models/head_model.h"

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

fitting::CalibrationResult StereoResult() {
  fitting::CalibrationResult r;
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
  return r;
}

TEST(Exports, OpenCvYamlLoadsAndReproducesTheRectification) {
  const fitting::CalibrationResult r = StereoResult();
  const std::string dir = TempDir("opencv");
  const std::string path = dir + "/calibration.yaml";
  WriteOpenCvYaml(r, path);
  cv::FileStorage fs(path, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  cv::Mat M1, D1, M2, D2, R, T, R1, R2, P1, P2, Q;
  fs["M1"] >> M1;
  fs["D1"] >> D1;
  fs["M2"] >> M2;
  fs["D2"] >> D2;
  fs["R"] >> R;
  fs["T"] >> T;
  fs["R1"] >> R1;
  fs["R2"] >> R2;
  fs["P1"] >> P1;
  fs["P2"] >> P2;
  fs["Q"] >> Q;
  EXPECT_EQ(int(fs["image_width"]), 640);
  EXPECT_DOUBLE_EQ(M1.at<double>(0, 0), 582.0);
  EXPECT_DOUBLE_EQ(D1.at<double>(0, 4), -0.01);
  EXPECT_DOUBLE_EQ(T.at<double>(0, 0), -0.0648);
  // Recomputing the rectification from the loaded calibration gives the stored one.
  cv::Mat r1, r2, p1, p2, q;
  cv::stereoRectify(M1, D1, M2, D2, cv::Size(640, 480), R, T, r1, r2, p1, p2, q, cv::CALIB_ZERO_DISPARITY, -1);
  EXPECT_LT(cv::norm(r1 - R1), 1e-9);
  EXPECT_LT(cv::norm(p2 - P2), 1e-6);
  // And it rectifies: a point seen by both cameras lands on the same row.
  for (const cv::Point3d X : {cv::Point3d(0.1, -0.05, 0.8), cv::Point3d(-0.2, 0.1, 1.5), cv::Point3d(0.0, 0.15, 0.4)}) {
    std::vector<cv::Point2d> pl, pr;
    cv::Mat rvec;
    cv::Rodrigues(R, rvec);
    cv::projectPoints(std::vector<cv::Point3d>{X}, cv::Mat::zeros(3, 1, CV_64F), cv::Mat::zeros(3, 1, CV_64F), M1, D1, pl);
    cv::projectPoints(std::vector<cv::Point3d>{X}, rvec, T, M2, D2, pr);
    std::vector<cv::Point2d> ul, ur;
    cv::undistortPoints(pl, ul, M1, D1, R1, P1);
    cv::undistortPoints(pr, ur, M2, D2, R2, P2);
    EXPECT_NEAR(ul[0].y, ur[0].y, 1e-3) << X;
    // Q maps disparity back to the depth along the rectified axis.
    const double disparity = ul[0].x - ur[0].x;
    cv::Mat v = (cv::Mat_<double>(4, 1) << ul[0].x, ul[0].y, disparity, 1.0);
    cv::Mat w = Q * v;
    const cv::Mat Xr = R1 * (cv::Mat_<double>(3, 1) << X.x, X.y, X.z);
    EXPECT_NEAR(w.at<double>(2) / w.at<double>(3), Xr.at<double>(2), 1e-6 * X.z + 1e-9) << X;
  }
}

TEST(Exports, RosKalibrAndMrcalFilesHaveTheValues) {
  const fitting::CalibrationResult r = StereoResult();
  const std::string dir = TempDir("others");
  std::vector<std::string> skipped;
  const auto written = WriteAllExports(r, models::DefaultRobotConfig(), nullptr, dir, &skipped);
  EXPECT_TRUE(skipped.empty()) << skipped.front();
  EXPECT_EQ(written.size(), 6u);
  const std::string ros = Slurp(dir + "/ros_left.yaml");
  EXPECT_NE(ros.find("distortion_model: plumb_bob"), std::string::npos);
  EXPECT_NE(ros.find("data: [582, 0, 322, 0, 581, 238, 0, 0, 1]"), std::string::npos) << ros;
  const std::string kalibr = Slurp(dir + "/kalibr_camchain.yaml");
  EXPECT_NE(kalibr.find("intrinsics: [579, 580, 317, 243]"), std::string::npos) << kalibr;
  EXPECT_NE(kalibr.find("k3 (and k4..k6) dropped"), std::string::npos);
  EXPECT_NE(kalibr.find("T_cn_cnm1"), std::string::npos);
  const std::string mr = Slurp(dir + "/right.cameramodel");
  EXPECT_NE(mr.find("'lensmodel':  'LENSMODEL_OPENCV5'"), std::string::npos);
  EXPECT_NE(mr.find("-0.0648"), std::string::npos);
  // Loads in mrcal when the Debian package python3-mrcal is installed.
  int st = 0;
  Shell("/usr/bin/python3 -c 'import mrcal' 2>/dev/null", &st);
  if (st != 0) GTEST_SKIP() << "python3-mrcal not installed: mrcal load not checked (apt install python3-mrcal)";
  const std::string out = Shell("/usr/bin/python3 -c \"import mrcal; m = mrcal.cameramodel('" + dir +
                                  "/right.cameramodel'); print(m.intrinsics()[0], ' '.join('%.6f' % x for x in m.intrinsics()[1][:5]), "
                                  "' '.join('%.6f' % x for x in m.extrinsics_rt_fromref()[3:]))\" 2>&1",
                              &st);
  EXPECT_EQ(st, 0) << out;
  EXPECT_NE(out.find("LENSMODEL_OPENCV5 579.000000 580.000000 317.000000 243.000000 -0.100000 -0.064800 0.000700 0.001200"),
            std::string::npos)
      << out;
}

TEST(Exports, OwlPwmHeaderCompilesWithTheCourseNaming) {
  fitting::CalibrationResult r = StereoResult();
  const models::RobotConfig cfg = models::DefaultRobotConfig();
  fitting::Parameter c;
  c.name = "servo.Rx.centre_us";
  c.value = 1538.6;
  c.sigma = 0.4;
  c.unit = "us";
  r.Set(c);
  const fitting::LimitsEvaluation lim =
      fitting::EvaluateLimits(cfg, {{models::kRx, false, 1230, fitting::LimitCause::kEndStop},
                                    {models::kLy, true, 1950, fitting::LimitCause::kSocketRim}}, nullptr, 10);
  const std::string dir = TempDir("owlpwm");
  WriteOwlPwmHeader(r, cfg, &lim, dir + "/owl-pwm.h");
  // A course-style program that uses the values; it prints them for the check.
  std::ofstream(dir + "/main.cpp") << "#include <cstdio>\n#include \"owl-pwm.h\"\nint main() {\n"
                                      "  std::printf(\"%d %d %d %d %d %d %d %d %d %d %d %d %d %d %d %d %.3f\\n\", RyB, RyT, RxR, RxL, "
                                      "LyB, LyT, LxR, LxL, NeckR, NeckL, RxC, RyC, LxC, LyC, NeckC, LyRange, OWLCAL_IPD_MM);\n"
                                      "  return 0;\n}\n";
  int st = 0;
  const std::string cc = Shell("c++ -std=c++11 -Wall -Werror -o " + dir + "/prog " + dir + "/main.cpp 2>&1", &st);
  ASSERT_EQ(st, 0) << cc;
  const std::string out = Shell(dir + "/prog", &st);
  ASSERT_EQ(st, 0);
  // Guide values except: Rx low end-stop at 1230 (+10 margin), Ly high (bottom) rim at 1950,
  // fitted Rx centre 1539.
  EXPECT_EQ(out, "1120 2000 1890 1240 1940 1180 1850 1180 1100 1950 1539 1530 1545 1580 1530 -760 65.000\n");
}

}  // namespace
}  // namespace owlcal::reports
