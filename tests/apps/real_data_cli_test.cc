// Command-line checks of the real-data commands as a user runs them: free-standing tags
// (detect-tags). Exit codes: 0 ok, 1 failed, 2 usage (apps/command_registry.h).
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tests/apps/run_owlcal.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

class RealDataCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_real_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

std::string Slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST_F(RealDataCliTest, DetectTagsWritesEveryTagAndKeepsRepeatedIds) {
  apriltag_family_t* f = tag36h11_create();
  image_u8_t* im = apriltag_to_image(f, 12);
  cv::Mat cells(im->height, im->width, CV_8U);
  for (int y = 0; y < im->height; ++y)
    for (int x = 0; x < im->width; ++x) cells.at<uint8_t>(y, x) = im->buf[y * im->stride + x];
  free(im->buf);
  free(im);
  tag36h11_destroy(f);
  cv::Mat big;
  cv::resize(cells, big, cv::Size(), 10, 10, cv::INTER_NEAREST);
  cv::Mat img(240, 400, CV_8U, cv::Scalar(255));
  big.copyTo(img(cv::Rect(30, 60, 100, 100)));
  big.copyTo(img(cv::Rect(250, 70, 100, 100)));  // the same id again
  ASSERT_TRUE(cv::imwrite((dir_ / "two.png").string(), img));
  const fs::path csv = dir_ / "tags.csv";
  const auto r = RunOwlcal("detect-tags '" + (dir_ / "two.png").string() + "' --out '" + csv.string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const std::string text = Slurp(csv);
  EXPECT_NE(text.find("image,family,id,hamming,decision_margin,x0,y0"), std::string::npos) << text;
  size_t rows = 0, pos = 0;
  while ((pos = text.find(",tag36h11,12,", pos)) != std::string::npos) ++rows, ++pos;
  EXPECT_EQ(rows, 2u) << text;
  EXPECT_NE(text.find("repeated_id"), std::string::npos) << text;

  const auto bad = RunOwlcal("detect-tags '" + (dir_ / "two.png").string() + "' --family tag37h11 --out x.csv");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("tag37h11"), std::string::npos) << bad.output;
}

}  // namespace
}  // namespace owlcal
