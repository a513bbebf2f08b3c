// One detection path for every command: on eight kit2020-chessboard pairs made blurred and
// washed out (the views the former calibrate-images fast check gave up on), `owlcal detect`,
// `calibrate-images` and `check-calibration` find the board in the same 16 images.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

class DetectionParityCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_detection_parity_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "pairs");
    // Gaussian blur (sigma 2.5 px) and contrast 0.4 about mid-grey, written losslessly.
    const fs::path kit = test_data::SharedData() + "/owl-real/kit2020-chessboard";
    for (int i : {1, 4, 8, 10, 13, 16, 19, 22})
      for (const char* eye : {"left", "right"}) {
        const std::string stem = std::string(eye) + std::to_string(i);
        const cv::Mat img = cv::imread((kit / (stem + ".jpg")).string(), cv::IMREAD_COLOR);
        ASSERT_FALSE(img.empty()) << stem;
        cv::Mat b;
        cv::GaussianBlur(img, b, cv::Size(0, 0), 2.5);
        b.convertTo(b, -1, 0.4, 128 * 0.6);
        ASSERT_TRUE(cv::imwrite((dir_ / "pairs" / (stem + ".png")).string(), b));
      }
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
  const std::string target_ = test_data::SharedData() + "/targets/owl-kit-chessboard.yaml";
};

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t pos = text.find(what); pos != std::string::npos; pos = text.find(what, pos + 1)) ++n;
  return n;
}

TEST_F(DetectionParityCliTest, DetectCalibrateImagesAndCheckCalibrationFindTheSameBoards) {
  const std::string pairs = (dir_ / "pairs").string();
  const auto det = RunOwlcal("detect '" + pairs + "' --pairs --target '" + target_ + "' --out '" +
                             (dir_ / "obs.csv").string() + "'");
  EXPECT_EQ(det.exit_code, 0) << det.output;
  EXPECT_NE(det.output.find("detected the target in 16 of 16 eye images"), std::string::npos) << det.output;

  const auto cal = RunOwlcal("calibrate-images '" + pairs + "' --target '" + target_ + "' --no-report --out '" +
                             (dir_ / "cal").string() + "'");
  ASSERT_TRUE(fs::exists(dir_ / "cal" / "results.json")) << cal.output;
  std::ifstream in(dir_ / "cal" / "results.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  const nlohmann::json& d = j.at("diagnostics").at("detections");
  ASSERT_EQ(d.size(), 8u);
  int found = 0;
  for (const auto& p : d) found += p.at("left_found").get<bool>() + p.at("right_found").get<bool>();
  EXPECT_EQ(found, 16) << d.dump(1);
  EXPECT_EQ(cal.output.find("board found in"), std::string::npos) << cal.output;

  const auto chk = RunOwlcal("check-calibration '" + pairs + "' --calib '" + (dir_ / "cal").string() + "' --target '" +
                             target_ + "' --out '" + (dir_ / "check").string() + "'");
  EXPECT_TRUE(fs::exists(dir_ / "check" / "check.json")) << chk.output;
  EXPECT_EQ(Count(chk.output, "board not found"), 0u) << chk.output;
}

TEST_F(DetectionParityCliTest, CalibrateImagesSaysWhatItTriedWhereNoBoardIsFound) {
  // A pair whose left image has no board: a blank grey frame.
  cv::imwrite((dir_ / "pairs" / "left1.png").string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(128, 128, 128)));
  const auto cal = RunOwlcal("calibrate-images '" + (dir_ / "pairs").string() + "' --target '" + target_ +
                             "' --no-report --out '" + (dir_ / "cal").string() + "'");
  EXPECT_NE(cal.output.find("left eye: board found in 7 of 8 images; pair 1: chessboard 9x6 not found; tried classic "
                            "9x6, sb 9x6"),
            std::string::npos)
      << cal.output;
}

}  // namespace
}  // namespace owlcal
