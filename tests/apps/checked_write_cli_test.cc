// Every write the command line makes is checked: a write that fails (a full disk, a file-size
// limit) is an error that names the file and exits non-zero, and the final name never holds a
// file cut short. The board is drawn here (no shared data); no network is used.
#include <sys/resource.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "owlcal_version.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;
using test_cli::RunResult;

class CheckedWriteCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_checked_write_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // OpenCV's sample board (data/targets/opencv-sample-chessboard.yaml): 9 x 6 inner corners,
    // so 10 x 7 squares of 40 px on a white margin.
    cv::Mat img(7 * 40 + 160, 10 * 40 + 160, CV_8UC1, cv::Scalar(255));
    for (int r = 0; r < 7; ++r)
      for (int c = 0; c < 10; ++c)
        if ((r + c) % 2 == 0) cv::rectangle(img, cv::Rect(80 + 40 * c, 80 + 40 * r, 40, 40), cv::Scalar(0), cv::FILLED);
    image_ = (dir_ / "board.png").string();
    ASSERT_TRUE(cv::imwrite(image_, img));
    target_ = std::string(OWLCAL_SOURCE_DIR) + "/data/targets/opencv-sample-chessboard.yaml";
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }
  RunResult Detect(const std::string& out) {
    return RunOwlcal("detect '" + image_ + "' --target '" + target_ + "' --out '" + out + "'");
  }
  fs::path dir_;
  std::string image_, target_;
};

TEST_F(CheckedWriteCliTest, DetectWritesItsCornersWhenTheDiskHasRoom) {
  const std::string out = (dir_ / "obs.csv").string();
  const RunResult r = Detect(out);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("54 corners"), std::string::npos) << r.output;
  EXPECT_GT(fs::file_size(out), 54u * 50u);
}

// Regression: `detect --out /dev/full` reported "54 corners written" and exited 0 although the
// write failed with ENOSPC.
TEST_F(CheckedWriteCliTest, DetectToAFullDiskIsAnErrorNamingTheFile) {
  const RunResult r = Detect("/dev/full");
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("/dev/full"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("No space left"), std::string::npos) << r.output;
  EXPECT_EQ(r.output.find("corners written"), std::string::npos) << r.output;
}

// Regression: on a disk with 4 KB free, detect left a CSV cut mid-row under its final name. A
// file-size limit of 2 KB (inherited by the child; SIGXFSZ ignored, so the write fails with
// EFBIG) stands in for the nearly full disk: the command fails and no obs.csv exists.
TEST_F(CheckedWriteCliTest, DetectThatCannotWriteItAllLeavesNoFileUnderTheFinalName) {
  const std::string out = (dir_ / "obs.csv").string();
  rlimit old{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &old), 0);
  rlimit lim = old;
  lim.rlim_cur = 2048;
  auto* old_handler = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &lim), 0);
  const RunResult r = Detect(out);
  setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(out), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out)) << r.output;
  for (const auto& e : fs::directory_iterator(dir_))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

}  // namespace
}  // namespace owlcal
