// owlcal pose-calibration on a folder `owlcal calibrate` wrote (the stereo
// protocol and a short servo sweep, tests/data/protocols): at a verged command it writes the
// centre pose's files (results.json, calibration.yaml, the course's xml, exports/) with the
// prediction's sigma and, on the virtual Owl, its truth; a command outside the robot's limits
// is refused naming the servo. The calibration folder also holds the pixel -> PWM map
// (exports/pixel_pwm.csv and owl-pwm.h's OwlPixelToPwm). The pose's folder holds one run, as a
// calibration folder does (apps/output_folder.h). One calibration serves every test.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fitting/opencv_calib_file.h"
#include "owlcal_version.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

std::string ReadText(const fs::path& p) {
  std::ifstream f(p);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

class PoseCalibrationCli : public ::testing::Test {
 protected:
  // `calibrate` with the stereo protocol and a short servo sweep into root_/cal, once.
  static void SetUpTestSuite() {
    if (test_cli::OwlcalBinary().empty()) return;
    root_ = fs::temp_directory_path() / ("owlcal_pose_cli_" + std::to_string(::getpid()));
    fs::remove_all(root_);
    const std::string sweep = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/servo_sweep_small.yaml";
    const auto cal = RunOwlcal("calibrate --quiet --no-figures --protocols stereo '" + sweep + "' --out '" +
                               (root_ / "cal").string() + "'");
    calibrate_output_ = cal.output;
    calibrated_ = cal.exit_code == 0;
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    if (!root_.empty()) fs::remove_all(root_, ec);
  }
  void SetUp() override {
    ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
    ASSERT_TRUE(calibrated_) << calibrate_output_;
  }
  static fs::path root_;
  static std::string calibrate_output_;
  static bool calibrated_;
};
fs::path PoseCalibrationCli::root_;
std::string PoseCalibrationCli::calibrate_output_;
bool PoseCalibrationCli::calibrated_ = false;

TEST_F(PoseCalibrationCli, WritesTheCentrePoseFilesAtAVergedCommandWithSigmaAndTruth) {
  const fs::path root = root_;
  // The pixel -> PWM map is exported with the head.
  const std::string csv = ReadText(root / "cal" / "exports" / "pixel_pwm.csv");
  EXPECT_NE(csv.find("eye,x_px,y_px,ok,clamped,pan_us,tilt_us,delta_pan_us,delta_tilt_us"), std::string::npos);
  EXPECT_NE(ReadText(root / "cal" / "exports" / "owl-pwm.h").find("static inline void OwlPixelToPwm("),
            std::string::npos);

  // Default robot centres: Rx 1545 Ry 1530 Lx 1545 Ly 1580 Neck 1530; 36 us toe-in per eye.
  const fs::path out = root / "pose";
  const auto r = RunOwlcal("pose-calibration --calib '" + (root / "cal").string() +
                           "' 1509 1530 1581 1580 1530 --approach -1 0 1 0 0 --out '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* f : {"results.json",
                        "calibration.yaml",
                        "intrinsics.xml",
                        "extrinsics.xml",
                        "exports/ros_left.yaml",
                        "exports/kalibr_camchain.yaml",
                        "exports/owl-pwm.h"})
    EXPECT_TRUE(fs::exists(out / f)) << f << "\n" << r.output;
  EXPECT_NE(ReadText(out / "calibration.yaml").find("Q:"), std::string::npos);
  std::ifstream f(out / "results.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  int with_truth = 0;
  for (const auto& p : j.at("parameters")) {
    const std::string name = p.at("name");
    if (name.rfind("stereo.", 0) != 0 || !p.contains("truth") || !p.at("truth").is_number()) continue;
    ++with_truth;
    const double sigma = p.at("sigma").get<double>();
    ASSERT_GT(sigma, 0) << name;
    EXPECT_LT(std::abs(p.at("value").get<double>() - p.at("truth").get<double>()), 4 * sigma) << name << "\n"
                                                                                              << r.output;
  }
  EXPECT_GE(with_truth, 7) << r.output;
  EXPECT_EQ(j.at("inputs").at("pose").at("pwm_us"), nlohmann::json({1509, 1530, 1581, 1580, 1530}));

  const auto bad = RunOwlcal("pose-calibration --calib '" + (root / "cal").string() +
                             "' 1509 1530 2500 1580 1530 --out '" + (root / "bad").string() + "'");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("Lx = 2500"), std::string::npos) << bad.output;
}

std::string RunIdOfJson(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f).value("run_id", "");
}

// Every file of the pose's folder carries the pose run's id; a second pose into the same folder
// removes the first's files; --out the calibration folder itself is refused, the calibration kept.
TEST_F(PoseCalibrationCli, ThePoseFolderHoldsOneRun) {
  const fs::path out = root_ / "pose_runs";
  const std::string pose = "pose-calibration --calib '" + (root_ / "cal").string() + "' --out '" + out.string() + "' ";
  const auto first = RunOwlcal(pose + "1509 1530 1581 1580 1530");
  ASSERT_EQ(first.exit_code, 0) << first.output;
  const std::string id = RunIdOfJson(out / "results.json");
  ASSERT_FALSE(id.empty()) << first.output;
  EXPECT_EQ(RunIdOfJson(out / "exports" / "owlcal_run.json"), id);
  for (const char* file : {"calibration.yaml", "intrinsics.xml", "extrinsics.xml"})
    EXPECT_EQ(fitting::ReadOpenCvCalibration((out / file).string()).run_id, id) << file;
  EXPECT_EQ(ReadText(out / ".owlcal_run"), id + "\n");
  std::ifstream f(out / "results.json");
  const nlohmann::json j = nlohmann::json::parse(f);
  EXPECT_EQ(j.at("inputs").at("calibration_run_id"), RunIdOfJson(root_ / "cal" / "results.json"));
  EXPECT_EQ(j.at("inputs").at("software").at("name"), "owlcal");

  std::ofstream(out / "exports" / "stale.yaml") << "an earlier run's export\n";
  const auto second = RunOwlcal(pose + "1545 1530 1545 1580 1530");
  ASSERT_EQ(second.exit_code, 0) << second.output;
  EXPECT_NE(second.output.find("removed what an earlier run left in " + out.string() + ": results.json, "),
            std::string::npos)
      << second.output;
  const std::string id2 = RunIdOfJson(out / "results.json");
  EXPECT_NE(id2, id);
  EXPECT_EQ(RunIdOfJson(out / "exports" / "owlcal_run.json"), id2);
  EXPECT_FALSE(fs::exists(out / "exports" / "stale.yaml"));

  const std::string cal_results = ReadText(root_ / "cal" / "results.json");
  const auto onto = RunOwlcal("pose-calibration --calib '" + (root_ / "cal").string() + "' --out '" +
                              (root_ / "cal").string() + "' 1509 1530 1581 1580 1530");
  EXPECT_EQ(onto.exit_code, 2) << onto.output;
  EXPECT_NE(onto.output.find("--calib " + (root_ / "cal").string() + " is the output folder"), std::string::npos)
      << onto.output;
  EXPECT_EQ(ReadText(root_ / "cal" / "results.json"), cal_results);
  EXPECT_TRUE(fs::exists(root_ / "cal" / "evaluation.json"));
}

}  // namespace
}  // namespace owlcal
