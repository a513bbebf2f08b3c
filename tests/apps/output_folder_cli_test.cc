// An output folder never mixes runs (apps/output_folder.h, fitting/calibration_folder.h), as a user
// meets it: calibrate-images on a good set, then on an unusable one into the same folder. The
// unusable run said "calibration.yaml and exports not written" but left the good run's
// calibration.yaml, xml files and exports/, and `range-images --calib` read them as current.
// Then the other readers of a result (compare-sessions, fit-toe-in, fit-head).
// OpenCV's stereo sample with the 25 mm square of its calibration sample (every export written).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "fitting/opencv_calib_file.h"
#include "tests/apps/run_owlcal.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

std::string JsonRunId(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f).value("run_id", "");
}

std::string FileText(const fs::path& p) {
  std::ifstream f(p);
  std::ostringstream s;
  s << f.rdbuf();
  return s.str();
}

class OutputFolderCliTest : public test_cli::SampleBoardCliTest {
 protected:
  OutputFolderCliTest() : SampleBoardCliTest("output_folder_cli") {}
  // calibrate-images on the sample into OUT, with `extra` flags.
  test_cli::RunResult Calibrate(const std::string& extra) const {
    return RunOwlcal(CalibrateImagesArgs("out") + " " + extra);
  }
  static std::string Sample() { return test_data::SharedData() + "/opencv-stereo-chessboard"; }
  fs::path Out() const { return dir_ / "out"; }
};

TEST_F(OutputFolderCliTest, AnUnusableRunLeavesNoEarlierCalibrationLookingCurrent) {
  const auto good = Calibrate("");
  ASSERT_EQ(good.exit_code, 0) << good.output;
  // Every file of the run carries its id.
  const std::string id = JsonRunId(Out() / "results.json");
  ASSERT_FALSE(id.empty());
  EXPECT_EQ(JsonRunId(Out() / "evaluation.json"), id);
  EXPECT_EQ(JsonRunId(Out() / "exports" / "owlcal_run.json"), id);
  for (const char* f : {"calibration.yaml", "intrinsics.xml", "extrinsics.xml"})
    EXPECT_EQ(fitting::ReadOpenCvCalibration((Out() / f).string()).run_id, id) << f;
  fs::copy_file(Out() / "calibration.yaml", dir_ / "good_calibration.yaml");

  // The same images with the eyes exchanged: T_x > 0, unusable.
  const auto bad = Calibrate("--swap");
  ASSERT_EQ(bad.exit_code, 1) << bad.output;
  ASSERT_NE(bad.output.find("verdict: unusable"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("removed what an earlier run left in " + Out().string() + ": results.json"),
            std::string::npos)
      << bad.output;
  const std::string bad_id = JsonRunId(Out() / "results.json");
  EXPECT_FALSE(bad_id.empty());
  EXPECT_NE(bad_id, id);
  EXPECT_EQ(JsonRunId(Out() / "evaluation.json"), bad_id);
  for (const char* f : {"calibration.yaml", "intrinsics.xml", "extrinsics.xml", "exports"})
    EXPECT_FALSE(fs::exists(Out() / f)) << f << " of the earlier run is still there";

  // range-images on the folder: the unusable result is refused, and there is no calibration.yaml.
  const std::string range = "range-images '" + Sample() + "' --out '" + (dir_ / "ranges").string() + "' --calib ";
  const auto on_folder = RunOwlcal(range + "'" + Out().string() + "'");
  EXPECT_EQ(on_folder.exit_code, 1) << on_folder.output;
  EXPECT_NE(on_folder.output.find("verdict is unusable"), std::string::npos) << on_folder.output;
  const auto on_yaml = RunOwlcal(range + "'" + (Out() / "calibration.yaml").string() + "'");
  EXPECT_EQ(on_yaml.exit_code, 1) << on_yaml.output;
  EXPECT_NE(on_yaml.output.find("no such calibration file"), std::string::npos) << on_yaml.output;

  // A folder an older owlcal left mixed (the good run's calibration.yaml next to the unusable
  // run's results.json): every reader refuses it, naming the files and their runs.
  fs::copy_file(dir_ / "good_calibration.yaml", Out() / "calibration.yaml");
  for (const std::string& cmd : {range + "'" + (Out() / "calibration.yaml").string() + "'",
                                 std::string("report --no-figures '") + Out().string() + "'"}) {
    const auto r = RunOwlcal(cmd);
    EXPECT_EQ(r.exit_code, 1) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("holds files of different runs"), std::string::npos) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("run " + id + ": calibration.yaml"), std::string::npos) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("run " + bad_id + ": results.json"), std::string::npos) << cmd << "\n" << r.output;
  }
  EXPECT_FALSE(fs::exists(dir_ / "ranges" / "ranges.csv"));
}

// A folder of the user's that happens to hold report/ and tables/ is refused, not emptied; one a
// stopped owlcal run left (only its run marker and figures/) is cleaned.
TEST_F(OutputFolderCliTest, OnlyWhatOwlcalWroteIsRemoved) {
  fs::create_directories(Out() / "report");
  fs::create_directories(Out() / "tables");
  std::ofstream(Out() / "report" / "notes.txt") << "my lab notes\n";
  std::ofstream(Out() / "tables" / "mine.csv") << "a,b\n1,2\n";
  const auto refused = Calibrate("");
  EXPECT_NE(refused.exit_code, 0) << refused.output;
  EXPECT_NE(refused.output.find(Out().string() + ": holds tables, report but nothing that says owlcal wrote them"),
            std::string::npos)
      << refused.output;
  EXPECT_TRUE(fs::exists(Out() / "report" / "notes.txt"));
  EXPECT_TRUE(fs::exists(Out() / "tables" / "mine.csv"));
  EXPECT_FALSE(fs::exists(Out() / "results.json"));

  // The same names under a stopped run's marker: owlcal's, so removed, and the new run marks it.
  fs::remove_all(Out());
  fs::create_directories(Out() / "figures");
  std::ofstream(Out() / ".owlcal_run") << "20260101T000000Z-00000000\n";
  const auto good = Calibrate("");
  ASSERT_EQ(good.exit_code, 0) << good.output;
  EXPECT_NE(good.output.find("removed what an earlier run left in " + Out().string() + ": figures"), std::string::npos)
      << good.output;
  std::ifstream marker(Out() / ".owlcal_run");
  std::string id;
  std::getline(marker, id);
  EXPECT_EQ(id, JsonRunId(Out() / "results.json"));
}

// compare-sessions, fit-toe-in and fit-head read a results.json of a calibration folder only when
// the folder holds one run, as range-images and report do: here an older owlcal's leftover, a
// results.json of another run beside this run's calibration.yaml and exports.
TEST_F(OutputFolderCliTest, EveryReaderOfAResultRefusesAFolderOfTwoRuns) {
  const auto good = Calibrate("");
  ASSERT_EQ(good.exit_code, 0) << good.output;
  const std::string id = JsonRunId(Out() / "results.json");
  ASSERT_FALSE(id.empty());
  const std::string other = "20260101T000000Z-00000000";
  nlohmann::json results;
  {
    std::ifstream f(Out() / "results.json");
    results = nlohmann::json::parse(f);
  }
  results["run_id"] = other;
  std::ofstream(Out() / "results.json") << results.dump(1) << "\n";

  const std::string results_json = (Out() / "results.json").string();
  std::ofstream(dir_ / "sets.csv") << "calibration,Rx,Ry,Lx,Ly\n"
                                   << Out().string() << ",1509,1530,1581,1580\n"
                                   << results_json << ",1545,1530,1545,1580\n";
  for (const std::string& cmd :
       {"compare-sessions '" + Out().string() + "' '" + results_json + "'",
        "fit-toe-in '" + (dir_ / "sets.csv").string() + "' --out '" + (dir_ / "toe").string() + "'",
        "fit-head '" + (Out() / "observations.csv").string() + "' --intrinsics '" + results_json + "' --out '" +
            (dir_ / "head").string() + "'"}) {
    const auto r = RunOwlcal(cmd);
    EXPECT_EQ(r.exit_code, 1) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find(Out().string() + " holds files of different runs"), std::string::npos) << cmd << "\n"
                                                                                                   << r.output;
    EXPECT_NE(r.output.find("run " + other + ": results.json"), std::string::npos) << cmd << "\n" << r.output;
    EXPECT_NE(r.output.find("run " + id + ": evaluation.json, calibration.yaml"), std::string::npos) << cmd << "\n"
                                                                                                     << r.output;
  }
  // fit-toe-in names each set it could not use and writes no head fit from them.
  const std::string toe_md = FileText(dir_ / "toe" / "toe_in_fit.md");
  EXPECT_EQ(toe_md.find("servo.Rx.deg_per_us = "), std::string::npos) << toe_md;
  EXPECT_FALSE(fs::exists(dir_ / "head" / "head_result.json"));
}

}  // namespace
}  // namespace owlcal
