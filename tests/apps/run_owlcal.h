#pragma once
// Runs the built `owlcal` binary as a user would (popen; exit code and stdout+stderr), for the
// command-line tests. The binary's path comes from OWLCAL_BINARY (tests/CMakeLists.txt); a test
// fixture skips when it is empty.
#include <sys/wait.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "tests/shared_data.h"

namespace owlcal::test_cli {

inline std::string OwlcalBinary() {
#ifdef OWLCAL_BINARY
  if (std::filesystem::exists(OWLCAL_BINARY)) return OWLCAL_BINARY;
#endif
  return "";
}

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

inline RunResult RunOwlcal(const std::string& args) {
  RunResult r;
  std::string cmd = OwlcalBinary();  // appended in place: GCC 12 warns (-Wrestrict) on a literal + string
  cmd.insert(cmd.begin(), '\'');
  cmd.append("' ").append(args).append(" 2>&1");
  FILE* pipe = popen(cmd.c_str(), "r");
  if (!pipe) return r;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof(buf), pipe)) > 0) r.output.append(buf, n);
  const int status = pclose(pipe);
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

// A fixture for `calibrate-images` on OpenCV's stereo chessboard sample: a fresh folder dir_
// (removed after the test) holding the sample's target file board.yaml; skips without the binary.
class SampleBoardCliTest : public ::testing::Test {
 protected:
  explicit SampleBoardCliTest(const std::string& name) : name_(name) {}
  void SetUp() override {
    if (OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = std::filesystem::temp_directory_path() / ("owlcal_" + name_ + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    std::ofstream t(dir_ / "board.yaml");
    t << "target_type: chessboard\nid: opencv-sample-25mm\ncols: 9\nrows: 6\nsquare_size_m: 0.025\n";
  }
  void TearDown() override {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
  }
  // `calibrate-images` on the sample (OpenCV-5 lens, flat board, no report) into dir_/out.
  std::string CalibrateImagesArgs(const std::string& out) const {
    return "calibrate-images '" + test_data::SharedData() + "/opencv-stereo-chessboard' --target '" +
           (dir_ / "board.yaml").string() + "' --model opencv5 --board-warp flat --no-report --out '" +
           (dir_ / out).string() + "'";
  }
  std::string name_;
  std::filesystem::path dir_;
};

}  // namespace owlcal::test_cli
