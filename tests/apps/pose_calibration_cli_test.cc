// owlcal pose-calibration on a folder `owlcal calibrate` wrote (the stereo
// protocol and a short servo sweep, tests/data/protocols): at a verged command it writes the
// centre pose's files (results.json, calibration.yaml, the course's xml, exports/) with the
// prediction's sigma and, on the virtual Owl, its truth; a command outside the robot's limits
// is refused naming the servo. The calibration folder also holds the pixel -> PWM map
// (exports/pixel_pwm.csv and owl-pwm.h's OwlPixelToPwm).
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

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

TEST(PoseCalibrationCli, WritesTheCentrePoseFilesAtAVergedCommandWithSigmaAndTruth) {
  ASSERT_FALSE(test_cli::OwlcalBinary().empty()) << "the owlcal binary is not built";
  const fs::path root = fs::temp_directory_path() / ("owlcal_pose_cli_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const std::string sweep = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/servo_sweep_small.yaml";
  const auto cal = RunOwlcal("calibrate --quiet --no-figures --protocols stereo '" + sweep + "' --out '" +
                             (root / "cal").string() + "'");
  ASSERT_EQ(cal.exit_code, 0) << cal.output;
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
  fs::remove_all(root);
}

}  // namespace
}  // namespace owlcal
