#pragma once
// A calibration folder holds the files of one run. Every file a calibration run writes there
// carries the run's id (apps/output_folder.h makes it): results.json and evaluation.json
// `run_id`, calibration.yaml, intrinsics.xml and extrinsics.xml the string node `owlcal_run_id`,
// and exports/owlcal_run.json `run_id` with the list of export files it covers. A reader of a
// calibration (LoadStereoRig, `owlcal report`) checks that the files it may read belong to one
// run, so a failed or unusable run can never leave an earlier run's calibration looking current.
//
//   fitting::CheckOneRun("kit-cal");  // throws "kit-cal holds files of different runs: ..."
#include <string>
#include <vector>

namespace owlcal::fitting {

// The files of a calibration folder that carry a run id, relative to the folder.
inline constexpr const char* kRunIdFiles[] = {"results.json",
                                              "evaluation.json",
                                              "calibration.yaml",
                                              "intrinsics.xml",
                                              "extrinsics.xml",
                                              "exports/owlcal_run.json"};
// exports/owlcal_run.json: {"run_id": ID, "files": ["ros_left.yaml", ...]} (names within exports/).
inline constexpr const char* kExportsRunFile = "exports/owlcal_run.json";

struct FileRunId {
  std::string file;    // relative to the folder ("results.json", "exports/ros_left.yaml")
  std::string run_id;  // "" when the file carries none
};

// The run id of each run file of `dir` that exists (kRunIdFiles), then of every other file in
// exports/: the id of exports/owlcal_run.json when it lists the file, else "". Throws naming the
// file when one cannot be read.
std::vector<FileRunId> RunIdsOfFolder(const std::string& dir);

// Why the files of `dir` are not of one run ("" when they are): two ids differ, or one file
// carries an id and another none. Names every file with its id. A folder whose files carry no id
// at all (the course's stereo_calib files, owlcal before run ids) is one run.
std::string MixedRunsError(const std::string& dir);
// Throws std::runtime_error with MixedRunsError when it is not empty.
void CheckOneRun(const std::string& dir);

// True for the name of a file a calibration folder's readers take from that folder
// (results.json, evaluation.json, calibration.yaml, intrinsics.xml, extrinsics.xml): a reader
// given such a file checks its folder with CheckOneRun.
bool IsRunFileName(const std::string& file_name);

// What every reader of a calibration does before reading `path`: a folder is checked with
// CheckOneRun, a file of a calibration folder (IsRunFileName) by its folder's CheckOneRun; any
// other file (head_result.json, an observations CSV) is left alone.
void CheckOneRunOfPath(const std::string& path);

}  // namespace owlcal::fitting
