// calibrate-images --fix (fitting/fix_list.h) as a user runs it on OpenCV's stereo sample (with
// the 25 mm square its calibration sample was given, so that every export is written): the held
// k3 is 0 in results.json (held, sigma 0), calibration.md, calibration.yaml and the exports; a
// list item it does not know, or a coefficient the chosen model lacks, is a usage error naming it.
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"
#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

class CalibrateImagesFixCliTest : public test_cli::SampleBoardCliTest {
 protected:
  CalibrateImagesFixCliTest() : SampleBoardCliTest("calibrate_images_fix_cli") {}
  std::string Args(const std::string& out) const { return CalibrateImagesArgs(out); }
};

std::string Slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

TEST_F(CalibrateImagesFixCliTest, HeldK3IsZeroAndMarkedHeldEverywhere) {
  const auto r = RunOwlcal(Args("fixed") + " --fix k3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  const fitting::CalibrationResult res = fitting::ReadResultJson((dir_ / "fixed" / "results.json").string());
  for (const char* name : {"left.k3", "right.k3"}) {
    const fitting::Parameter* p = res.Find(name);
    ASSERT_NE(p, nullptr) << name;
    EXPECT_EQ(p->value, 0.0) << name;
    EXPECT_TRUE(p->held) << name;
    EXPECT_EQ(p->sigma, 0.0) << name;
    EXPECT_FALSE(p->determined) << name;
  }
  EXPECT_TRUE(res.Find("left.k2")->determined);
  EXPECT_EQ(res.inputs.at("fix"), nlohmann::json::array({"k3"}));
  const std::string md = Slurp(dir_ / "fixed" / "calibration.md");
  EXPECT_NE(md.find("| left.k3 | 0.0000 | held |"), std::string::npos) << md;
  const fitting::OpenCvStereoCalibration cv =
      fitting::ReadOpenCvCalibration((dir_ / "fixed" / "calibration.yaml").string());
  EXPECT_EQ(cv.D1.at<double>(4), 0.0);
  EXPECT_EQ(cv.D2.at<double>(4), 0.0);
  for (const char* e : {"exports/ros_left.yaml", "exports/kalibr_camchain.yaml", "exports/left.cameramodel"}) {
    const std::string text = Slurp(dir_ / "fixed" / e);
    EXPECT_NE(text.find("held by --fix (not fitted): left.k3 = 0"), std::string::npos) << e << ":\n" << text;
  }
  // Without --fix, k3 floats.
  const auto free = RunOwlcal(Args("free"));
  ASSERT_EQ(free.exit_code, 0) << free.output;
  const fitting::CalibrationResult f = fitting::ReadResultJson((dir_ / "free" / "results.json").string());
  EXPECT_NE(f.Find("left.k3")->value, 0.0);
  EXPECT_FALSE(f.Find("left.k3")->held);
}

TEST_F(CalibrateImagesFixCliTest, UnknownItemsAndMissingCoefficientsAreUsageErrors) {
  const auto bad = RunOwlcal(Args("bad") + " --fix k3,principal");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("unknown item 'principal'"), std::string::npos) << bad.output;
  const auto k4 = RunOwlcal(Args("k4") + " --fix k4");
  EXPECT_EQ(k4.exit_code, 2) << k4.output;
  EXPECT_NE(k4.output.find("the opencv5 model has no k4"), std::string::npos) << k4.output;
}

}  // namespace
}  // namespace owlcal
