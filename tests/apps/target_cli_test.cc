// `owlcal target`: the sheet and its YAML are written together, and the YAML drives the
// detection of the rasterised sheet (pdftoppm, scripts/install-deps.sh) at true scale.
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <map>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "calib/target_file.h"
#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;
using test_cli::RunResult;

class TargetCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_target_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(TargetCliTest, SampleBoardInSquaresNeedsATrueSizeThenPrintsAndDetectsAtIt) {
  const std::string sample = test_data::SharedData() + "/targets/opencv-sample-chessboard.yaml";
  const RunResult no_size = RunOwlcal("target '" + sample + "' --out '" + (dir_ / "s.pdf").string() + "'");
  EXPECT_EQ(no_size.exit_code, 2) << no_size.output;
  EXPECT_NE(no_size.output.find("--square-mm"), std::string::npos) << no_size.output;
  EXPECT_FALSE(fs::exists(dir_ / "s.pdf"));

  const fs::path pdf = dir_ / "sample18.pdf";
  const RunResult r = RunOwlcal("target '" + sample + "' --square-mm 18 --paper A4 --out '" + pdf.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  ASSERT_TRUE(fs::exists(pdf));
  const calib::TargetFile tf = calib::LoadTargetFileWithUnit((dir_ / "sample18.yaml").string());
  EXPECT_EQ(tf.unit, "m");
  EXPECT_EQ(tf.target.cols, 9);
  EXPECT_EQ(tf.target.rows, 6);
  EXPECT_NEAR(tf.target.square_m, 0.018, 1e-12);

  ASSERT_EQ(
      std::system(
          ("pdftoppm -r 150 -gray -png -singlefile '" + pdf.string() + "' '" + (dir_ / "page").string() + "'").c_str()),
      0)
      << "pdftoppm failed or is missing (scripts/install-deps.sh installs poppler-utils)";
  const cv::Mat page = cv::imread((dir_ / "page.png").string(), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(page.empty());
  const calib::TargetDetection d = calib::DetectTarget(page, tf.target, {});
  ASSERT_TRUE(d.found) << d.message;
  std::map<int, Eigen::Vector2d> by_id;
  for (size_t i = 0; i < d.corner_ids.size(); ++i) by_id[d.corner_ids[i]] = d.pixels[i];
  // Board diagonal (corner 0 to corner 53) in mm at 150 dpi: sqrt(8^2 + 5^2) squares of 18 mm.
  const double diag_mm = (by_id.at(53) - by_id.at(0)).norm() * 25.4 / 150;
  EXPECT_NEAR(diag_mm, 18.0 * std::sqrt(89.0), 0.1);  // 0.6 px at 150 dpi; 1 % printer scaling is 1.7 mm
}

TEST_F(TargetCliTest, AprilGridSvgGetsItsYamlAndAWrongSizeOptionIsRefused) {
  const std::string grid = test_data::SharedData() + "/targets/aprilgrid-6x6.yaml";
  const RunResult bad = RunOwlcal("target '" + grid + "' --square-mm 20 --out '" + (dir_ / "g.svg").string() + "'");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("--tag-size-mm"), std::string::npos) << bad.output;
  const RunResult r =
      RunOwlcal("target '" + grid + "' --tag-size-mm 30 --out '" + (dir_ / "g.svg").string() + "' --paper 300x400");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const calib::TargetDefinition t = calib::LoadTargetFile((dir_ / "g.yaml").string());
  EXPECT_NEAR(t.tag_size_m, 0.030, 1e-12);
  EXPECT_NEAR(t.tag_spacing, 0.3, 1e-12);
  EXPECT_NE(r.output.find("300.0 x 400.0 mm"), std::string::npos) << r.output;
  const RunResult wrong_ext = RunOwlcal("target '" + grid + "' --out '" + (dir_ / "g.png").string() + "'");
  EXPECT_EQ(wrong_ext.exit_code, 2) << wrong_ext.output;
}

}  // namespace
}  // namespace owlcal
