#pragma once
// The output folder of a run that writes a result (`calibrate`, `fit-datasets`,
// `calibrate-images`, `pose-calibration`, `fit-vergence`, `fit-toe-in`): every run gets a run id
// that each file it writes carries (fitting/calibration_folder.h), and before any work it removes
// what an earlier run left there, so the folder never mixes runs: a run that fails or ends
// unusable leaves no earlier calibration looking current. The recordings (datasets/) are never
// removed. Each file is written atomically (io/atomic_file.h), so a run stopped half way leaves
// fewer files of this run, never a part of one, and a reader's CheckOneRun still sees one run.
//
//   apps::CheckInputOutsideRun(out, calib_dir, "--calib");  // a run never removes what it reads
//   const std::string run_id = apps::StartRun(out, progress);  // before any work
//
// Only what an owlcal run wrote is removed: a folder that holds one of those names (a `report/`
// of the user's, say) with nothing to show that owlcal wrote it is refused, and nothing in it is
// touched.
#include <functional>
#include <string>
#include <vector>

namespace owlcal::apps {

// A fresh run id: the UTC time and 32 random bits, "20250314T163605Z-3f9a1c2e".
std::string NewRunId();

// What a run writes at the top of its folder (never datasets/, the recordings): results.json,
// evaluation.json, calibration.yaml, intrinsics.xml, extrinsics.xml, robot_corrected.yaml,
// calibration.md, observations.csv, exports/, figures/, tables/, report/; fit-vergence's
// vergence_fit.md and vergence_rows.csv; fit-toe-in's toe_in_fit.md, toe_in_sets.csv and sets/.
const std::vector<std::string>& RunOutputNames();

// The file every calibration run writes first into its folder, holding its run id: it marks the
// folder as owlcal's even when the run was stopped before it wrote anything else.
inline constexpr const char* kRunMarkerName = ".owlcal_run";

// True when `out` shows that owlcal wrote it: the run marker, exports/owlcal_run.json, an
// OpenCV calibration file with owlcal_run_id, or a results.json that is owlcal's (a run_id, or
// software.name or inputs.software.name "owlcal": every owlcal version wrote the first).
bool IsOwlcalOutputFolder(const std::string& out);

// Removes every RunOutputNames entry of `out` (and the temporaries a killed atomic write of one
// left there), then writes the run marker with `run_id`; returns the names removed, in
// RunOutputNames order. Creates `out` when missing. Throws naming the path when one cannot be
// removed, and when `out` holds one of those names but is not IsOwlcalOutputFolder (then nothing
// is removed).
std::vector<std::string> RemoveEarlierRun(const std::string& out, const std::string& run_id);

// Starts a run in `out`: a new run id (NewRunId), what an earlier run left removed
// (RemoveEarlierRun) and, when something was, one line to `say`: "removed what an earlier run
// left in OUT: results.json, exports". Returns the run id. Called before any work, so a folder
// it refuses costs nothing.
std::string StartRun(const std::string& out, const std::function<void(const std::string&)>& say);

// Throws UsageError naming `input` and `what` (the option: "--calib") when `input` is `out`
// itself or lies in one of the RunOutputNames of `out`: StartRun would remove what the run is
// about to read.
void CheckInputOutsideRun(const std::string& out, const std::string& input, const std::string& what);

}  // namespace owlcal::apps
