// An output folder never mixes runs (apps/output_folder.h, fitting/calibration_folder.h), as a user
// meets it: calibrate-images on a good set, then on an unusable one into the same folder. The
// unusable run said "calibration.yaml and exports not written" but left the good run's
// calibration.yaml, xml files and exports/, and `range-images --calib` read them as current.
// Then the other readers of a result (compare-sessions, fit-toe-in, fit-head), the other writers
// of a result folder (fit-vergence, fit-toe-in) and calibrate-images' refusal before any work.
// OpenCV's stereo sample with the 25 mm square of its calibration sample (every export written).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "calib/observation_io.h"
#include "fitting/opencv_calib_file.h"
#include "tests/apps/run_owlcal.h"
#include "tests/fitting/toe_in_synthetic.h"
#include "tests/shared_data.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

std::string JsonRunId(const fs::path& p) {
  std::ifstream f(p);
  return nlohmann::json::parse(f).value("run_id", "");
}

// The run id in a folder's run marker ("" without one).
std::string MarkerRunId(const fs::path& dir) {
  std::ifstream f(dir / ".owlcal_run");
  std::string id;
  std::getline(f, id);
  return id;
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

// fit-vergence and fit-toe-in write a result folder as calibrate does: every result carries the
// run's id, what an earlier run left goes first (a longer earlier toe-in run's sets/N too), and a
// folder of the user's holding one of those names is refused, untouched.
TEST_F(OutputFolderCliTest, FitVergenceAndFitToeInFoldersHoldOneRun) {
  const fs::path v = dir_ / "vergence";
  const std::string log = test_data::SharedData() + "/owl-real/noble2020-vergence-range/vergence_runs.csv";
  const std::string fit_vergence =
      "fit-vergence '" + log + "' --distance-column actual_distance_cm --out '" + v.string() + "'";
  const auto v1 = RunOwlcal(fit_vergence);
  ASSERT_EQ(v1.exit_code, 0) << v1.output;
  const std::string v_id = JsonRunId(v / "results.json");
  EXPECT_FALSE(v_id.empty()) << v1.output;
  EXPECT_EQ(MarkerRunId(v), v_id);
  const auto v2 = RunOwlcal(fit_vergence);
  ASSERT_EQ(v2.exit_code, 0) << v2.output;
  EXPECT_NE(v2.output.find("removed what an earlier run left in " + v.string() +
                           ": results.json, vergence_fit.md, vergence_rows.csv"),
            std::string::npos)
      << v2.output;
  EXPECT_NE(JsonRunId(v / "results.json"), v_id);
  EXPECT_EQ(MarkerRunId(v), JsonRunId(v / "results.json"));

  const fs::path mine = dir_ / "mine";
  fs::create_directories(mine);
  std::ofstream(mine / "vergence_fit.md") << "my notes\n";
  const auto refused =
      RunOwlcal("fit-vergence '" + log + "' --distance-column actual_distance_cm --out '" + mine.string() + "'");
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find(mine.string() + ": holds vergence_fit.md but nothing that says owlcal wrote them"),
            std::string::npos)
      << refused.output;
  EXPECT_EQ(FileText(mine / "vergence_fit.md"), "my notes\n");
  EXPECT_FALSE(fs::exists(mine / "results.json"));

  // fit-toe-in on synthetic sets (observation files, each calibrated by the command).
  const test_toe_in::Truth t;
  std::mt19937 rng(5);
  std::string rows;
  for (size_t i = 0; i < test_toe_in::kSettings.size(); ++i) {
    const auto& st = test_toe_in::kSettings[i];
    const std::string name = "set" + std::to_string(i) + ".csv";
    calib::WriteObservationsCsv((dir_ / name).string(), test_toe_in::SynthesiseSet(t, st.rx, st.lx, &rng));
    rows += name + "," + std::to_string(st.rx) + ",1530," + std::to_string(st.lx) + ",1580\n";
  }
  const size_t last = test_toe_in::kSettings.size() - 1;
  std::ofstream(dir_ / "all.csv") << "calibration,Rx,Ry,Lx,Ly\n" << rows;
  std::ofstream(dir_ / "fewer.csv") << "calibration,Rx,Ry,Lx,Ly\n"
                                    << rows.substr(0, rows.rfind("set" + std::to_string(last)));
  const fs::path toe = dir_ / "toe";
  auto fit_toe_in = [&](const std::string& csv) {
    return RunOwlcal("fit-toe-in '" + (dir_ / csv).string() + "' --out '" + toe.string() + "'");
  };
  const auto t1 = fit_toe_in("all.csv");
  ASSERT_EQ(t1.exit_code, 0) << t1.output;
  ASSERT_TRUE(fs::exists(toe / "sets" / std::to_string(last) / "results.json")) << t1.output;
  const std::string t_id = JsonRunId(toe / "results.json");
  EXPECT_FALSE(t_id.empty()) << t1.output;
  EXPECT_EQ(JsonRunId(toe / "sets" / "0" / "results.json"), t_id);
  EXPECT_EQ(MarkerRunId(toe), t_id);
  const auto t2 = fit_toe_in("fewer.csv");
  ASSERT_EQ(t2.exit_code, 0) << t2.output;
  EXPECT_NE(t2.output.find("removed what an earlier run left in " + toe.string() +
                           ": results.json, toe_in_fit.md, toe_in_sets.csv, sets"),
            std::string::npos)
      << t2.output;
  EXPECT_FALSE(fs::exists(toe / "sets" / std::to_string(last))) << "the earlier run's last set is still there";
  const std::string t2_id = JsonRunId(toe / "results.json");
  EXPECT_NE(t2_id, t_id);
  EXPECT_EQ(JsonRunId(toe / "sets" / "0" / "results.json"), t2_id);
  EXPECT_EQ(MarkerRunId(toe), t2_id);

  // A set read from the folder the run empties first is refused before anything is removed.
  std::ofstream(dir_ / "inside.csv") << "calibration,Rx,Ry,Lx,Ly\n"
                                     << (toe / "sets" / "0").string() << ",1545,1530,1545,1580\n";
  const auto inside = fit_toe_in("inside.csv");
  EXPECT_EQ(inside.exit_code, 2) << inside.output;
  EXPECT_NE(inside.output.find((toe / "sets" / "0").string() + " lies in " + (toe / "sets").string()),
            std::string::npos)
      << inside.output;
  EXPECT_EQ(JsonRunId(toe / "sets" / "0" / "results.json"), t2_id);
}

// calibrate-images refuses a folder of the user's before it looks at the images (it used to
// detect and fit first, then refuse): here the image folder is empty, so any work would fail
// first, naming it. A mistyped option still leaves an earlier run in place.
TEST_F(OutputFolderCliTest, CalibrateImagesRefusesAForeignFolderBeforeAnyWork) {
  fs::create_directories(Out() / "report");
  std::ofstream(Out() / "report" / "notes.txt") << "my lab notes\n";
  const fs::path empty = dir_ / "no_images";
  fs::create_directories(empty);
  const auto refused = RunOwlcal("calibrate-images '" + empty.string() + "' --target '" +
                                 (dir_ / "board.yaml").string() + "' --out '" + Out().string() + "'");
  EXPECT_EQ(refused.exit_code, 1) << refused.output;
  EXPECT_NE(refused.output.find(Out().string() + ": holds report but nothing that says owlcal wrote them"),
            std::string::npos)
      << refused.output;
  EXPECT_EQ(refused.output.find("no left*/right* image pairs"), std::string::npos) << refused.output;
  EXPECT_EQ(FileText(Out() / "report" / "notes.txt"), "my lab notes\n");

  fs::remove_all(Out());
  fs::create_directories(Out());
  std::ofstream(Out() / ".owlcal_run") << "20260101T000000Z-00000000\n";
  std::ofstream(Out() / "results.json") << "{\"run_id\": \"20260101T000000Z-00000000\"}\n";
  const auto typo = RunOwlcal(CalibrateImagesArgs("out") + " --rig robot");
  EXPECT_EQ(typo.exit_code, 2) << typo.output;
  EXPECT_TRUE(fs::exists(Out() / "results.json")) << typo.output;
}

}  // namespace
}  // namespace owlcal
