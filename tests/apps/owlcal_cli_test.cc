// The `owlcal` command line as a user runs it: the built binary is executed with popen and its
// exit code and output are checked (exit codes: 0 ok, 1 failed, 2 usage; apps/command_registry.h).
// The binary's path comes from OWLCAL_BINARY (tests/CMakeLists.txt); without it, the binary is
// looked for next to the test's build folder (build/X/tests/<exe> -> build/X/owlcal), and the
// tests are skipped with a message when it has not been built. Network: loopback only.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "fitting/result.h"
#include "owlcal_version.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace owlcal_cli_test {

namespace fs = std::filesystem;

std::string OwlcalBinary() {
#ifdef OWLCAL_BINARY
  if (fs::exists(OWLCAL_BINARY)) return OWLCAL_BINARY;
#endif
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return "";
  const fs::path candidate = self.parent_path().parent_path() / "owlcal";
  return fs::exists(candidate) ? candidate.string() : "";
}

using ::owlcal::test_data::SharedData;

std::string SourceDir() { return OWLCAL_SOURCE_DIR; }

struct RunResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

RunResult RunOwlcal(const std::string& args) {
  RunResult r;
  std::string cmd =
      OwlcalBinary();  // appended in place: GCC 12 warns (-Wrestrict, false positive) on a literal + string
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

// A loopback port nobody listens on: bound once by the kernel's choice, then released.
int ClosedLoopbackPort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  int port = 0;
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0 &&
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) == 0)
    port = ntohs(addr.sin_port);
  close(fd);
  return port;
}

class OwlcalCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (OwlcalBinary().empty())
      GTEST_SKIP() << "the owlcal binary is not built (build the 'owlcal' target first; expected next to tests/)";
  }
};

TEST_F(OwlcalCliTest, HelpExitsZeroAndListsSubcommands) {
  const RunResult r = RunOwlcal("--help");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  for (const char* sub : {"detect", "fit", "move", "calibrate", "run", "sim", "report"})
    EXPECT_NE(r.output.find(std::string("  ") + sub + " "), std::string::npos) << "--help does not list " << sub;
}

TEST_F(OwlcalCliTest, VersionPrintsTheVersion) {
  const RunResult r = RunOwlcal("--version");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find(OWLCAL_VERSION), std::string::npos) << r.output;
}

TEST_F(OwlcalCliTest, UnknownOptionIsAUsageError) {
  const RunResult r = RunOwlcal("--no-such-option");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  const RunResult s = RunOwlcal("no-such-command");
  EXPECT_EQ(s.exit_code, 2) << s.output;
  const RunResult t = RunOwlcal("");
  EXPECT_EQ(t.exit_code, 2) << "no subcommand: " << t.output;
}

TEST_F(OwlcalCliTest, MoveWithoutRobotIsAUsageError) {
  const RunResult r = RunOwlcal("move 1500 1500 1500 1500 1500");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--robot"), std::string::npos) << r.output;
  const RunResult s = RunOwlcal("move --robot 127.0.0.1:1 1500 1500 1500");
  EXPECT_EQ(s.exit_code, 2) << "three pulse widths: " << s.output;
}

// Regression: `move ''` was read as 0 and `move 0x600` as 1536. Pulse widths are decimal only, and
// refused before any connection (the closed port is never tried).
TEST_F(OwlcalCliTest, MoveRefusesEmptyAndHexPulseWidths) {
  const int port = ClosedLoopbackPort();
  ASSERT_GT(port, 0);
  const std::string robot = "move --robot 127.0.0.1:" + std::to_string(port) + " ";
  const RunResult empty = RunOwlcal(robot + "'' 1500 1500 1500 1500");
  EXPECT_EQ(empty.exit_code, 2) << empty.output;
  EXPECT_NE(empty.output.find("pulse width Rx = '' is not an integer"), std::string::npos) << empty.output;
  const RunResult hex = RunOwlcal(robot + "1500 1500 1500 1500 0x600");
  EXPECT_EQ(hex.exit_code, 2) << hex.output;
  EXPECT_NE(hex.output.find("pulse width Neck = '0x600' is not an integer"), std::string::npos) << hex.output;
  const RunResult big = RunOwlcal(robot + "1500 15000 1500 1500 1500");
  EXPECT_EQ(big.exit_code, 2) << big.output;
  EXPECT_NE(big.output.find("pulse width Ry = 15000 is outside [0, 9999]"), std::string::npos) << big.output;
  EXPECT_EQ(big.output.find("connect"), std::string::npos) << big.output;
}

TEST_F(OwlcalCliTest, MoveToAClosedPortFailsWithAClearMessage) {
  const int port = ClosedLoopbackPort();
  ASSERT_GT(port, 0);
  const std::string address = "127.0.0.1:" + std::to_string(port);
  const RunResult r = RunOwlcal("move --robot " + address + " --timeout-ms 2000 1500 1500 1500 1500 1500");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find(address), std::string::npos) << "message should name the address: " << r.output;
  EXPECT_NE(r.output.find("connect"), std::string::npos) << r.output;
}

// detect + fit on the OpenCV stereo sample set (13 pairs, 9x6, square = 1): the left camera's
// fx should be near OpenCV's 532.8 (docs/conventions.md, Facts) and the baseline near 3.327 squares.
TEST_F(OwlcalCliTest, DetectAndFitOnOpenCvSampleImages) {
  const std::string images = SharedData() + "/opencv-stereo-chessboard";
  if (!fs::exists(images + "/left01.jpg")) GTEST_SKIP() << "shared data not found: " << images;
  const std::string target = SourceDir() + "/data/targets/opencv-sample-chessboard.yaml";
  ASSERT_TRUE(fs::exists(target)) << target;
  const fs::path dir = fs::path(::testing::TempDir()) / ("owlcal_cli_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string obs = (dir / "obs.csv").string();

  const RunResult d = RunOwlcal("detect '" + images + "' --pairs --target '" + target + "' --out '" + obs + "'");
  ASSERT_EQ(d.exit_code, 0) << d.output;
  EXPECT_NE(d.output.find("detected the target in 26 of 26"), std::string::npos) << d.output;
  ASSERT_TRUE(fs::exists(obs));
  EXPECT_GT(fs::file_size(obs), 1000u);

  const std::string out = (dir / "fit").string();
  const RunResult f = RunOwlcal("fit '" + obs + "' --target '" + target + "' --out '" + out + "'");
  ASSERT_EQ(f.exit_code, 0) << f.output;
  ASSERT_TRUE(fs::exists(out + "/results.json")) << f.output;
  EXPECT_TRUE(fs::exists(out + "/calibration.yaml")) << f.output;
  const fitting::CalibrationResult result = fitting::ReadResultJson(out + "/results.json");
  const fitting::Parameter* fx = result.Find("left.fx");
  ASSERT_NE(fx, nullptr) << "results.json has no left.fx";
  std::printf("owlcal fit: left.fx = %.3f +- %.3f (OpenCV 532.8)\n", fx->value, fx->sigma);
  EXPECT_NEAR(fx->value, 532.8, 0.005 * 532.8);
  EXPECT_GT(fx->sigma, 0);
  const fitting::Parameter* baseline = result.Find("stereo.baseline_squares");
  ASSERT_NE(baseline, nullptr) << "results.json has no stereo.baseline_squares";
  std::printf("owlcal fit: stereo.baseline_squares = %.4f (OpenCV 3.327)\n", baseline->value);
  EXPECT_NEAR(baseline->value, 3.327, 0.02);

  // A missing observation file is a failure naming the file, not a crash.
  const RunResult m = RunOwlcal("fit '" + (dir / "missing.csv").string() + "' --out '" + out + "2'");
  EXPECT_NE(m.exit_code, 0);
  EXPECT_NE(m.output.find("missing.csv"), std::string::npos) << m.output;
  fs::remove_all(dir);
}

// calibrate-images on the course's kit2020 set writes what calibrate writes: the course's xml in
// millimetres agreeing with the course's own reference files (kit2020 reference/, cv::FileStorage),
// calibration.yaml in metres, the ROS, Kalibr and mrcal exports, and the report in OUT/report/.
TEST_F(OwlcalCliTest, CalibrateImagesWritesTheCourseFilesInMillimetresAndEveryExport) {
  const std::string images = SharedData() + "/owl-real/kit2020-chessboard";
  const std::string target = SourceDir() + "/data/targets/owl-kit-chessboard.yaml";
  const fs::path dir = fs::path(::testing::TempDir()) / ("owlcal_cli_kit_" + std::to_string(getpid()));
  fs::remove_all(dir);
  // The course's reference files come from a flat-board fit: compare like with like (--board-warp
  // flat, whatever the cross-validation would choose).
  const RunResult r = RunOwlcal("calibrate-images '" + images + "' --target '" + target +
                                "' --board-warp flat --out '" + dir.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"results.json",
                        "evaluation.json",
                        "calibration.yaml",
                        "intrinsics.xml",
                        "extrinsics.xml",
                        "exports/ros_left.yaml",
                        "exports/ros_right.yaml",
                        "exports/kalibr_camchain.yaml",
                        "exports/left.cameramodel",
                        "exports/right.cameramodel",
                        "report/index.html"})
    EXPECT_TRUE(fs::exists(dir / f)) << f << "\n" << r.output;
  EXPECT_FALSE(fs::exists(dir / "report" / "report")) << "the report belongs in OUT/report/index.html";
  {
    std::ifstream f(dir / "report" / "index.html");
    const std::string html((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
    EXPECT_NE(html.find("data:image/png;base64,"), std::string::npos) << "figures are embedded";
    EXPECT_EQ(html.find("src=\"../"), std::string::npos) << "no figure is a relative file";
    for (const char* absent : {"Vergence ranging", "Step response", "Servo limits", "Ground-truth", "guide-owl"})
      EXPECT_EQ(html.find(absent), std::string::npos) << absent << ": no robot was involved";
    for (const char* link : {"../results.json", "../calibration.yaml", "../intrinsics.xml", "../exports/"})
      if (html.find(link) != std::string::npos) {
        EXPECT_TRUE(fs::exists(dir / "report" / link)) << "broken link " << link;
      }
  }
  // No servo maps from images: owl-pwm.h is not written, and the output says why.
  EXPECT_FALSE(fs::exists(dir / "exports" / "owl-pwm.h"));
  EXPECT_NE(r.output.find("owl-pwm.h: no servo map was fitted"), std::string::npos) << r.output;

  const std::string ref = images + "/reference/";
  cv::FileStorage ri(ref + "intrinsics.xml", cv::FileStorage::READ), re(ref + "extrinsics.xml", cv::FileStorage::READ);
  cv::FileStorage oi((dir / "intrinsics.xml").string(), cv::FileStorage::READ);
  cv::FileStorage oe((dir / "extrinsics.xml").string(), cv::FileStorage::READ);
  ASSERT_TRUE(ri.isOpened() && re.isOpened() && oi.isOpened() && oe.isOpened());
  auto mat = [](const cv::FileStorage& fs, const char* n) {
    cv::Mat m;
    fs[n] >> m;
    return m;
  };
  EXPECT_EQ(std::string(oe["length_unit"]), "mm");
  const cv::Mat t_ref = mat(re, "T"), t = mat(oe, "T");
  std::printf("kit2020 T [mm]: owlcal %.2f %.2f %.2f, course %.2f %.2f %.2f\n",
              t.at<double>(0),
              t.at<double>(1),
              t.at<double>(2),
              t_ref.at<double>(0),
              t_ref.at<double>(1),
              t_ref.at<double>(2));
  EXPECT_NEAR(cv::norm(t - t_ref), 0.0, 1.0);  // mm, not m: a unit slip would be 64 mm off
  EXPECT_NEAR(mat(oe, "Q").at<double>(3, 2) / mat(re, "Q").at<double>(3, 2), 1.0, 0.01);
  EXPECT_NEAR(mat(oi, "M1").at<double>(0, 0) / mat(ri, "M1").at<double>(0, 0), 1.0, 0.015);
  EXPECT_NEAR(mat(oi, "M2").at<double>(1, 1) / mat(ri, "M2").at<double>(1, 1), 1.0, 0.015);
  cv::FileStorage y((dir / "calibration.yaml").string(), cv::FileStorage::READ);
  EXPECT_NEAR(mat(y, "T").at<double>(0), t.at<double>(0) / 1000, 1e-12);
  fs::remove_all(dir);
}

}  // namespace owlcal_cli_test
}  // namespace owlcal
