// `owlcal range-images` on a long truth list says how far it has got: the work is linear in the
// rows, but 100,000 rows ran for minutes without a word. The calibration and the pair are made
// here (no shared data); no network is used.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fitting/opencv_calib_file.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;
using test_cli::RunResult;

class RangeImagesProgressCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_range_progress_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

// Regression: a 100,000-row truth CSV ran past 120 s with no progress line. 250 rows of one
// textured pair: a line after every 100 pairs, and all 250 are ranged.
TEST_F(RangeImagesProgressCliTest, ALongTruthListPrintsProgressLines) {
  // 320x240, f 292.5 px, no distortion: a small image keeps 250 pairs quick.
  models::CameraIntrinsics cam;
  cam.width = 320;
  cam.height = 240;
  cam.params = {292.5, 292.5, 159.5, 119.5, 0, 0, 0, 0, 0};
  models::Rigid3d right_from_left;
  right_from_left.rotation = Eigen::AngleAxisd(0.002, Eigen::Vector3d(0.1, 1, 0.05).normalized());
  right_from_left.translation = Eigen::Vector3d(-0.065, 0.0004, 0.0008);  // F(2,2) != 0
  const std::string calib = (dir_ / "calibration.yaml").string();
  fitting::WriteOpenCvCalibration(calib, fitting::MakeOpenCvCalibration(cam, cam, right_from_left));
  cv::Mat left(240, 320, CV_8UC3), right;
  cv::randu(left, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::GaussianBlur(left, left, cv::Size(5, 5), 1.5);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -19, 0, 1, 0);  // 19 px disparity: about 1 m
  cv::warpAffine(left, right, shift, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  ASSERT_TRUE(cv::imwrite((dir_ / "left1.png").string(), left));
  ASSERT_TRUE(cv::imwrite((dir_ / "right1.png").string(), right));
  {
    std::ofstream truth(dir_ / "truth.csv");
    truth << "left,right,distance_cm\n";
    for (int i = 0; i < 250; ++i) truth << "left1.png,right1.png,100\n";
  }
  const RunResult r = RunOwlcal("range-images '" + dir_.string() + "' --calib '" + calib + "' --truth '" +
                                (dir_ / "truth.csv").string() + "' --out '" + (dir_ / "out").string() + "'");
  EXPECT_NE(r.output.find("range-images: 100 of 250 pairs ranged"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("range-images: 200 of 250 pairs ranged"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("range-images: 300 of"), std::string::npos) << r.output;
  std::ifstream csv(dir_ / "out" / "ranges.csv");
  int lines = 0;
  for (std::string line; std::getline(csv, line);) ++lines;
  EXPECT_EQ(lines, 251) << r.output;  // header + one row per truth row
}

}  // namespace
}  // namespace owlcal
