// `owlcal check-calibration` on eight real kit2020 pairs: owlcal's own calibration of them
// (calibrate-images) is "still valid" (exit 0); the same calibration written as an OpenCV file
// with the right camera's principal point moved by 5 px is "recalibrate" (exit 3), naming what
// moved. (Independent check sets and every perturbation: tests/evaluation/calibration_check_test.cc.)
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fitting/opencv_calib_file.h"
#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;
using test_cli::RunResult;

class CheckCalibrationCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_check_calibration_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "new");
    // "New images": eight pairs of the kit set.
    const fs::path kit = test_data::SharedData() + "/owl-real/kit2020-chessboard";
    for (int i : {1, 4, 8, 10, 13, 16, 19, 22})
      for (const char* eye : {"left", "right"}) {
        const std::string name = std::string(eye) + std::to_string(i) + ".jpg";
        fs::copy_file(kit / name, dir_ / "new" / name);
      }
  }
  fs::path dir_;
  const std::string target_ = test_data::SharedData() + "/targets/owl-kit-chessboard.yaml";
};

TEST_F(CheckCalibrationCliTest, OwnCalibrationStillValidAndAMovedPrincipalPointIsFlagged) {
  const RunResult cal = RunOwlcal("calibrate-images '" + (dir_ / "new").string() + "' --target '" + target_ +
                                  "' --out '" + (dir_ / "cal").string() + "'");
  ASSERT_TRUE(fs::exists(dir_ / "cal" / "results.json")) << cal.output;
  const RunResult ok =
      RunOwlcal("check-calibration '" + (dir_ / "new").string() + "' --calib '" + (dir_ / "cal").string() +
                "' --target '" + target_ + "' --out '" + (dir_ / "ok").string() + "'");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("Verdict: still valid"), std::string::npos) << ok.output;
  std::ifstream in(dir_ / "ok" / "check.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  EXPECT_EQ(j["verdict"], "still valid");
  EXPECT_EQ(j["pairs"], 8);
  EXPECT_GT(double(j["fixed"]["sigma_rms_joint_px"]), 0.0);

  fitting::OpenCvStereoCalibration c = fitting::ReadOpenCvCalibration((dir_ / "cal" / "calibration.yaml").string());
  c.M2.at<double>(0, 2) += 5.0;
  const fs::path moved = dir_ / "moved.yaml";
  fitting::WriteOpenCvCalibration(moved.string(), c);
  const RunResult bad = RunOwlcal("check-calibration '" + (dir_ / "new").string() + "' --calib '" + moved.string() +
                                  "' --target '" + target_ + "' --out '" + (dir_ / "bad").string() + "'");
  EXPECT_EQ(bad.exit_code, 3) << bad.output;
  EXPECT_NE(bad.output.find("Verdict: recalibrate"), std::string::npos) << bad.output;
  EXPECT_TRUE(bad.output.find("- right.cx ") != std::string::npos ||
              bad.output.find("- stereo.ry_deg ") != std::string::npos)
      << bad.output;
  const RunResult squares = RunOwlcal("check-calibration '" + (dir_ / "new").string() + "' --calib '" + moved.string() +
                                      "' --target '" + test_data::SharedData() +
                                      "/targets/opencv-sample-chessboard.yaml' --out '" + (dir_ / "sq").string() + "'");
  EXPECT_EQ(squares.exit_code, 2) << "a board in squares cannot check a metric calibration: " << squares.output;
}

}  // namespace
}  // namespace owlcal
