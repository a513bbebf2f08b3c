// A calibration folder's readers take its files only when they belong to one run
// (fitting/calibration_folder.h): an unusable run that left an earlier run's calibration.yaml
// behind was read as current without a word.
#include "fitting/calibration_folder.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include <gtest/gtest.h>

#include "evaluation/range_images_ranging.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"

namespace owlcal::fitting {
namespace {

namespace fs = std::filesystem;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no error)";
}

// A stereo result: two 640x480 cameras (f 585 px), 65 mm apart, slightly rotated (F(2,2) != 0).
CalibrationResult StereoResult(const std::string& run_id) {
  CalibrationResult r;
  r.run_id = run_id;
  r.cameras[0] = models::CameraIntrinsics();
  r.cameras[1] = models::CameraIntrinsics();
  StereoEstimate s;
  s.right_from_left.rotation = Eigen::AngleAxisd(0.002, Eigen::Vector3d(0.1, 1, 0.05).normalized());
  s.right_from_left.translation = Eigen::Vector3d(-0.065, 0.0004, 0.0008);
  r.stereo = s;
  return r;
}

void WriteText(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p) << text;
}

class CalibrationFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("owlcal_calibration_folder_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Dir() const { return dir_.string(); }
  fs::path dir_;
};

TEST_F(CalibrationFolderTest, TheFilesOfOneRunAreRead) {
  const CalibrationResult r = StereoResult("run-a");
  WriteResultJson(r, (dir_ / "results.json").string());
  WriteOpenCvCalibration((dir_ / "calibration.yaml").string(), ToOpenCvCalibration(r));
  WriteOpenCvSplitFiles((dir_ / "intrinsics.xml").string(), (dir_ / "extrinsics.xml").string(), ToOpenCvCalibration(r));
  WriteText(dir_ / "evaluation.json", R"({"format": "owlcal-evaluation", "run_id": "run-a"})");
  WriteText(dir_ / "exports" / "owlcal_run.json", R"({"run_id": "run-a", "files": ["ros_left.yaml"]})");
  WriteText(dir_ / "exports" / "ros_left.yaml", "image_width: 640\n");
  EXPECT_EQ(MixedRunsError(Dir()), "");
  for (const auto& f : RunIdsOfFolder(Dir())) EXPECT_EQ(f.run_id, "run-a") << f.file;
  EXPECT_EQ(RunIdsOfFolder(Dir()).size(), 7u);
  EXPECT_EQ(ReadOpenCvCalibration((dir_ / "calibration.yaml").string()).run_id, "run-a");
  EXPECT_EQ(ReadResultJson((dir_ / "results.json").string()).run_id, "run-a");
  EXPECT_NO_THROW(LoadStereoRig(Dir()));
  EXPECT_NO_THROW(LoadStereoRig((dir_ / "calibration.yaml").string()));
  EXPECT_NO_THROW(LoadStereoRig((dir_ / "intrinsics.xml").string()));
}

// The case of the issue: an unusable run wrote its results.json next to an earlier run's
// calibration.yaml; every way of reading the folder now refuses, naming both files and ids.
TEST_F(CalibrationFolderTest, AnEarlierRunsCalibrationNextToANewResultIsRefused) {
  WriteOpenCvCalibration((dir_ / "calibration.yaml").string(), ToOpenCvCalibration(StereoResult("run-good")));
  WriteResultJson(StereoResult("run-new"), (dir_ / "results.json").string());
  const std::string why = MixedRunsError(Dir());
  EXPECT_NE(why.find("different runs"), std::string::npos) << why;
  EXPECT_NE(why.find("run run-good: calibration.yaml"), std::string::npos) << why;
  EXPECT_NE(why.find("run run-new: results.json"), std::string::npos) << why;
  for (const std::string& path : {Dir(), (dir_ / "calibration.yaml").string(), (dir_ / "results.json").string()})
    EXPECT_NE(ErrorOf([&] { LoadStereoRig(path); }).find("run run-good: calibration.yaml"), std::string::npos) << path;
  // A file carrying no id next to one that does is of another run too.
  fs::remove(dir_ / "calibration.yaml");
  WriteText(dir_ / "evaluation.json", R"({"format": "owlcal-evaluation"})");
  EXPECT_NE(MixedRunsError(Dir()).find("no run id: evaluation.json"), std::string::npos) << MixedRunsError(Dir());
}

TEST_F(CalibrationFolderTest, AnExportTheRunDidNotListIsOfAnotherRun) {
  WriteResultJson(StereoResult("run-a"), (dir_ / "results.json").string());
  WriteText(dir_ / "exports" / "owlcal_run.json", R"({"run_id": "run-a", "files": ["ros_left.yaml"]})");
  WriteText(dir_ / "exports" / "ros_left.yaml", "image_width: 640\n");
  WriteText(dir_ / "exports" / "kalibr_camchain.yaml", "cam0:\n");
  const std::string why = MixedRunsError(Dir());
  EXPECT_NE(why.find("no run id: exports/kalibr_camchain.yaml"), std::string::npos) << why;
  EXPECT_NE(why.find("run run-a: results.json, exports/owlcal_run.json, exports/ros_left.yaml."), std::string::npos)
      << why;
  // An exports folder without its run file: every export is of no known run.
  fs::remove(dir_ / "exports" / "owlcal_run.json");
  EXPECT_NE(MixedRunsError(Dir()).find("kalibr_camchain.yaml, exports/ros_left.yaml"), std::string::npos)
      << MixedRunsError(Dir());
}

TEST_F(CalibrationFolderTest, SplitFilesOfTwoRunsAreRefused) {
  WriteOpenCvSplitFiles(
      (dir_ / "intrinsics.xml").string(), (dir_ / "unused.xml").string(), ToOpenCvCalibration(StereoResult("run-a")));
  WriteOpenCvSplitFiles(
      (dir_ / "unused.xml").string(), (dir_ / "extrinsics.xml").string(), ToOpenCvCalibration(StereoResult("run-b")));
  const std::string why =
      ErrorOf([&] { ReadOpenCvSplitFiles((dir_ / "intrinsics.xml").string(), (dir_ / "extrinsics.xml").string()); });
  EXPECT_NE(why.find("'run-a'"), std::string::npos) << why;
  EXPECT_NE(why.find("'run-b'"), std::string::npos) << why;
  EXPECT_NE(why.find("different runs"), std::string::npos) << why;
  EXPECT_NE(ErrorOf([&] { LoadStereoRig(Dir()); }).find("different runs"), std::string::npos);
}

// The course's own files (and owlcal's before run ids) carry none: one run, read as before.
TEST_F(CalibrationFolderTest, FilesWithoutRunIdsAreOneRun) {
  WriteOpenCvSplitFiles(
      (dir_ / "intrinsics.xml").string(), (dir_ / "extrinsics.xml").string(), ToOpenCvCalibration(StereoResult("")));
  EXPECT_EQ(MixedRunsError(Dir()), "");
  EXPECT_NO_THROW(LoadStereoRig(Dir()));
  // Any other file name is read alone, whatever its folder holds.
  WriteResultJson(StereoResult("run-a"), (dir_ / "results.json").string());
  WriteOpenCvCalibration((dir_ / "mine.yaml").string(), ToOpenCvCalibration(StereoResult("")));
  EXPECT_NO_THROW(LoadStereoRig((dir_ / "mine.yaml").string()));
}

TEST_F(CalibrationFolderTest, AnUnusableResultIsNotARig) {
  CalibrationResult r = StereoResult("run-a");
  r.verdict = {{"status", "unusable"}, {"reasons", {"T_x > 0: the eyes are swapped (--swap)"}}};
  WriteResultJson(r, (dir_ / "results.json").string());
  const std::string why = ErrorOf([&] { LoadStereoRig(Dir()); });
  EXPECT_NE(why.find("verdict is unusable (T_x > 0"), std::string::npos) << why;
  EXPECT_NE(why.find("results.json"), std::string::npos) << why;
}

}  // namespace
}  // namespace owlcal::fitting
