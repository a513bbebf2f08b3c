#include "evaluation/range_images_ranging.h"

#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace owlcal::evaluation {
namespace {

// Parallel rig: no distortion, identity rotation, right camera 64 mm along +x of the left.
fitting::StereoRig ParallelRig(double f, double baseline_m) {
  fitting::StereoRig rig;
  for (int e = 0; e < 2; ++e) {
    rig.cameras[e].model = models::DistortionModel::kOpenCv5;
    rig.cameras[e].params = {f, f, 319.5, 239.5, 0, 0, 0, 0, 0};
  }
  rig.right_from_left = models::Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-baseline_m, 0, 0));
  return rig;
}

cv::Mat Texture(unsigned seed) {
  cv::Mat n(480, 640, CV_32F);
  cv::RNG rng(seed);
  rng.fill(n, cv::RNG::NORMAL, 128, 60);
  cv::GaussianBlur(n, n, cv::Size(0, 0), 1.5);
  cv::Mat out;
  n.convertTo(out, CV_8U, 2.0, -128);
  return out;
}

TEST(RangeImages, TriangulatesExactPixelsToTheTrueDepth) {
  const fitting::StereoRig rig = ParallelRig(585, 0.064);
  for (double z : {0.3, 1.0, 2.5}) {
    const Eigen::Vector3d x_left(0.05, -0.02, z);
    const Eigen::Vector3d x_right = rig.right_from_left * x_left;
    Eigen::Vector2d pl, pr;
    ASSERT_TRUE(rig.cameras[0].Project(x_left.data(), pl.data()));
    ASSERT_TRUE(rig.cameras[1].Project(x_right.data(), pr.data()));
    double gap = 1;
    const auto d = TriangulateDepth(rig, fitting::RigParameters(rig), pl, pr, Eigen::Vector3d::UnitZ(), &gap);
    ASSERT_TRUE(d.has_value());
    EXPECT_NEAR(*d, z, 1e-9);
    EXPECT_NEAR(gap, 0, 1e-9);
  }
}

// A textured fronto-parallel plane at depth Z: the right image is the left one shifted left
// by f B / Z. Ranging must return Z, and a baseline sigma of 1 mm must give Z sigma_B / B.
TEST(RangeImages, RangesShiftedPlaneAndPropagatesBaselineSigma) {
  const double f = 585, b = 0.064;
  fitting::StereoRig rig = ParallelRig(f, b);
  const int n = rig.NumParams();
  rig.covariance = Eigen::MatrixXd::Zero(n, n);
  rig.covariance(n - 3, n - 3) = 0.001 * 0.001;  // T_x sigma 1 mm
  const fitting::Rectification rect = fitting::RectifyRig(rig);
  EXPECT_NEAR(rect.baseline_m, b, 1e-12);
  const cv::Mat left = Texture(4);
  for (double z : {0.4, 0.9, 1.5}) {
    const double d = f * b / z;
    cv::Mat right;
    const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, -d, 0, 1, 0);
    cv::warpAffine(left, right, M, left.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
    RangeOptions o;
    const RangeMeasurement m = RangePair(left, right, rig, rect, o);
    ASSERT_TRUE(m.ok) << m.message;
    EXPECT_NEAR(m.range_m, z, z * z / (f * b) * 0.15) << "z=" << z;  // 0.15 px disparity
    EXPECT_NEAR(m.sigma_calib_m, z * 0.001 / b, 0.02 * z * 0.001 / b) << "z=" << z;
    EXPECT_NEAR(m.sigma_match_m, m.range_m / m.match.disparity_px * m.match.sigma_disparity_px, 1e-12);
    EXPECT_NEAR(m.sigma_m, std::hypot(m.sigma_calib_m, m.sigma_match_m), 1e-12);
  }
}

// results.json keeps the stereo fit's joint covariance, so a rig read back from it ranges with
// the focal-length/baseline correlation instead of independent sigmas.
TEST(RangeImages, ResultsJsonKeepsTheJointStereoCovariance) {
  const fitting::StereoRig rig = ParallelRig(585, 0.064);
  const int n = rig.NumParams();
  fitting::CalibrationResult r;
  r.cameras[0] = rig.cameras[0];
  r.cameras[1] = rig.cameras[1];
  fitting::StereoEstimate est;
  est.right_from_left = rig.right_from_left;
  for (int i = 0; i < n; ++i) est.full_names.push_back(std::string("p").append(std::to_string(i)));
  // fx of both eyes and T_x fully correlated (a common scale error), sigma 2 px and 0.2 mm.
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  g(0) = 2.0;
  g(1) = 2.0;
  g(9) = 2.0;
  g(10) = 2.0;
  g(n - 3) = -0.0002;
  est.full_covariance = g * g.transpose() + 1e-12 * Eigen::MatrixXd::Identity(n, n);
  est.covariance = est.full_covariance.bottomRightCorner(6, 6);
  r.stereo = est;
  fitting::Parameter fx;
  fx.name = "left.fx";
  fx.value = 585;
  fx.sigma = 2.0;
  fx.unit = "px";
  r.Set(fx);
  const fitting::CalibrationResult back = fitting::ResultFromJson(ToJson(r));
  ASSERT_TRUE(back.stereo.has_value());
  ASSERT_EQ(back.stereo->full_names.size(), size_t(n));
  EXPECT_NEAR((back.stereo->full_covariance - est.full_covariance).cwiseAbs().maxCoeff(), 0, 1e-18);
  const fitting::StereoRig read = fitting::RigFromResult(back);
  ASSERT_EQ(read.covariance.rows(), n);
  EXPECT_NEAR(read.covariance(0, n - 3), -2.0 * 0.0002, 1e-15);  // the correlation survived
  // A truncated matrix is named, not silently read.
  nlohmann::json j = ToJson(r);
  j["stereo"]["full_covariance"]["matrix"].erase(0);
  try {
    fitting::ResultFromJson(j);
    ADD_FAILURE() << "a truncated covariance was accepted";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("stereo.full_covariance"), std::string::npos) << e.what();
  }
}

TEST(RangeImages, TruthCsvReadsRoisAndNamesBadFields) {
  const std::string path = ::testing::TempDir() + "/truth_test.csv";
  {
    std::ofstream f(path);
    f << "left,right,distance_mm,roi_x,roi_y,roi_w,roi_h\nl1.jpg,r1.jpg,300,10,20,30,40\nl2.jpg,r2.jpg,4x0,,,,\n";
  }
  try {
    ReadRangeTruthCsv(path);
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(":3: column distance_mm = '4x0'"), std::string::npos) << e.what();
  }
  {
    std::ofstream f(path);
    f << "left,right,distance_mm,roi_x,roi_y,roi_w,roi_h\nl1.jpg,r1.jpg,300,10,20,30,40\nl2.jpg,r2.jpg,400,,,,\n";
  }
  const auto rows = ReadRangeTruthCsv(path);
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_NEAR(rows[0].distance_m, 0.3, 1e-12);
  EXPECT_EQ(rows[0].roi, cv::Rect(10, 20, 30, 40));
  EXPECT_EQ(rows[1].roi.area(), 0);
}

// Issue table "Silent wrong results (6)": range-images accepted nan or negative true distances and
// silently adjusted an out-of-image ROI. The reader refuses the distances and half-given ROIs; an
// ROI outside the rectified image is refused, naming the row.
TEST(RangeImages, TruthRefusesNanNegativeDistancesAndRoisOutsideTheImage) {
  const std::string path = ::testing::TempDir() + "/truth_hostile.csv";
  auto error = [&](const std::string& text) {
    std::ofstream(path, std::ios::trunc) << text;
    try {
      CheckRangeTruthRois(ReadRangeTruthCsv(path), cv::Size(640, 480));
    } catch (const std::runtime_error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::string head = "left,right,distance_cm,roi_x,roi_y,roi_w,roi_h\n";
  EXPECT_EQ(error(head + "l.jpg,r.jpg,nan,,,,\n"),
            path + ":2: column distance_cm = 'nan' is not a finite decimal number");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,-30,,,,\n"), path + ":2: column distance_cm = -30 is not positive");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,10,20,,\n"), path + ":2: column roi_w = '' is not an integer");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,-5,20,30,40\n"), path + ":2: column roi_x = -5 is outside [0, 100000]");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,10,20,3,40\n"), path + ":2: column roi_w = 3 is outside [5, 100000]");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,620,20,30,40\n"),
            path + ":2: roi 620 20 30 40 is not inside the 640x480 rectified image (refused, not clipped)");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,2147483640,20,30,40\n"),
            path + ":2: column roi_x = 2147483640 is outside [0, 100000]");
  EXPECT_EQ(error("left,right,distance_cm,roi_x\nl.jpg,r.jpg,30,5\n"),
            path + ":1: give all four of roi_x, roi_y, roi_w, roi_h or none");
  EXPECT_EQ(error("left,right,distance_cm,distance_mm\nl.jpg,r.jpg,30,300\n"),
            path + ":1: two distance columns, distance_cm and distance_mm");
  EXPECT_EQ(error(head + "l.jpg,r.jpg,30,600,400,40,80\n"), "");
  EXPECT_TRUE(RoiInsideImage(cv::Rect(600, 400, 40, 80), cv::Size(640, 480)));
  EXPECT_FALSE(RoiInsideImage(cv::Rect(601, 400, 40, 80), cv::Size(640, 480)));
}

}  // namespace
}  // namespace owlcal::evaluation
