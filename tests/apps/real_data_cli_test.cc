// Command-line checks of the real-data commands as a user runs them: free-standing tags
// (detect-tags), toe-in servo maps (fit-toe-in), ranging without distances (range-images), a
// mirrored set refused (calibrate-images). Exit codes: 0 ok, 1 failed, 2 usage (apps/command_registry.h).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/observation_io.h"
#include "fitting/result.h"
#include "owlcal_version.h"
#include "tests/apps/run_owlcal.h"
#include "tests/fitting/toe_in_synthetic.h"
#include "tests/shared_data.h"

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace owlcal {
namespace real_data_cli_test {

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

// fit-toe-in as a student runs it: a CSV of observation files (each set calibrated by the
// command) and the PWM values; synthetic sets with known per-eye scales.
TEST_F(RealDataCliTest, FitToeInCalibratesEachSetAndFitsTheScales) {
  const test_toe_in::Truth t;
  std::mt19937 rng(5);
  {
    std::ofstream f(dir_ / "sets.csv");
    f << "calibration,Rx,Ry,Lx,Ly\n";
    for (size_t i = 0; i < test_toe_in::kSettings.size(); ++i) {
      const auto& s = test_toe_in::kSettings[i];
      const std::string name = "set" + std::to_string(i) + ".csv";
      calib::WriteObservationsCsv((dir_ / name).string(), test_toe_in::SynthesiseSet(t, s.rx, s.lx, &rng));
      f << name << "," << s.rx << ",1530," << s.lx << ",1580\n";  // relative to the CSV's folder
    }
  }
  const auto r = RunOwlcal("fit-toe-in '" + (dir_ / "sets.csv").string() + "' --out '" + (dir_ / "out").string() + "'");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  const fitting::CalibrationResult res = fitting::ReadResultJson((dir_ / "out" / "results.json").string());
  for (const auto& [name, truth] : {std::pair<std::string, double>{"servo.Rx.deg_per_us", t.rx_deg_per_us},
                                    std::pair<std::string, double>{"servo.Lx.deg_per_us", t.lx_deg_per_us}}) {
    const fitting::Parameter* p = res.Find(name);
    ASSERT_NE(p, nullptr) << r.output;
    EXPECT_NEAR(p->value, truth, 3 * p->sigma) << name;
  }
  EXPECT_TRUE(fs::exists(dir_ / "out" / "sets" / "0" / "results.json"));
  EXPECT_TRUE(fs::exists(dir_ / "out" / "toe_in_sets.csv"));
  EXPECT_NE(r.output.find("chi2/dof"), std::string::npos) << r.output;
}

// Unknown distances: no truth file, every pair of the folder ranged with sigma and a status,
// the target chosen by texture.
TEST_F(RealDataCliTest, RangeImagesWithoutTruthRangesEveryPair) {
  const std::string data = test_data::SharedData();
  const auto r = RunOwlcal("range-images '" + data + "/owl-real/kit2020-distance-target1' --calib '" + data +
                           "/owl-real/kit2020-chessboard/reference/intrinsics.xml' --select texture --out '" +
                           (dir_ / "ranges").string() + "'");
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;  // 1 when a row is not ok
  const std::string csv = Slurp(dir_ / "ranges" / "ranges.csv");
  EXPECT_EQ(csv.rfind("name,status,true_cm,range_cm", 0), 0u) << csv;
  size_t rows = 0;
  for (char c : csv) rows += c == '\n';
  EXPECT_EQ(rows, 14u);  // header + 13 pairs
  const std::string md = Slurp(dir_ / "ranges" / "ranges.md");
  EXPECT_NE(md.find("13 of unknown distance"), std::string::npos) << md;
  EXPECT_NE(md.find("most textured"), std::string::npos) << md;
}

// With a truth, range-images splits the fitted scale: ranges.md's "Where the scale goes" table and
// scale_budget.json, matching measured by StereoSGBM at every template; the course's calibration
// has no covariance, and the budget says so instead of printing a sigma.
TEST_F(RealDataCliTest, RangeImagesWithTruthWritesTheScaleBudget) {
  const std::string data = test_data::SharedData();
  const auto r = RunOwlcal("range-images '" + data + "/owl-real/kit2020-distance-target1' --calib '" + data +
                           "/owl-real/kit2020-chessboard/reference/intrinsics.xml' --truth '" + OWLCAL_SOURCE_DIR +
                           "/data/real/kit2020_distance_target1.csv' --truth-sigma-cm 2 --out '" +
                           (dir_ / "ranges").string() + "'");
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1) << r.output;
  const std::string md = Slurp(dir_ / "ranges" / "ranges.md");
  EXPECT_NE(md.find("## Where the scale goes"), std::string::npos) << md;
  EXPECT_NE(md.find("| matching (disparity bias) |"), std::string::npos) << md;
  const auto j = nlohmann::json::parse(Slurp(dir_ / "ranges" / "scale_budget.json"));
  ASSERT_TRUE(j.at("ok").get<bool>()) << j.dump(2);
  EXPECT_EQ(j.at("matching").at("rows").get<int>(), j.at("num_rows").get<int>());
  EXPECT_TRUE(j.at("calibration").at("sigma_cov").is_null());
  EXPECT_TRUE(std::isfinite(j.at("matching").at("value").get<double>()));
  EXPECT_NEAR(j.at("matching").at("value").get<double>() + j.at("truth").at("value").get<double>(),
              j.at("b_minus_1").get<double>(),
              1e-12);
  bool says_no_covariance = false;
  for (const auto& n : j.at("notes"))
    says_no_covariance |= n.get<std::string>().find("no covariance") != std::string::npos;
  EXPECT_TRUE(says_no_covariance) << j.dump(2);
}

// A mirrored set calibrated without --mirror: refused (exit 1), the flags named, no exports.
TEST_F(RealDataCliTest, CalibrateImagesRefusesAMirroredSetAndNamesTheFlag) {
  const std::string data = test_data::SharedData();
  const fs::path out = dir_ / "mirrored";
  const auto r = RunOwlcal("calibrate-images '" + data + "/owl-real/darvill2019-chessboard/session3' --target '" +
                           std::string(OWLCAL_SOURCE_DIR) +
                           "/data/targets/owl-kit-chessboard.yaml' --no-report --out '" + out.string() + "'");
  EXPECT_EQ(r.exit_code, 1) << r.output;
  EXPECT_NE(r.output.find("--mirror"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("verdict: unusable"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out / "calibration.yaml"));
  const fitting::CalibrationResult res = fitting::ReadResultJson((out / "results.json").string());
  ASSERT_TRUE(res.verdict.is_object());
  EXPECT_EQ(res.verdict.at("status"), "unusable");
}

}  // namespace real_data_cli_test
}  // namespace owlcal
