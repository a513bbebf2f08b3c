#pragma once
// The output folder of a calibration run (`calibrate`, `fit-datasets`, `calibrate-images`):
// every run gets a run id that each file it writes carries (fitting/calibration_folder.h), and
// before it writes anything it removes what an earlier run left there, so the folder never
// mixes runs: a run that fails or ends unusable leaves no earlier calibration looking current.
// The recordings (datasets/) are never removed. Each file is written atomically
// (io/atomic_file.h), so a run stopped half way leaves fewer files of this run, never a part of
// one, and a reader's CheckOneRun still sees one run.
//
//   const std::string id = apps::NewRunId();
//   for (const auto& f : apps::RemoveEarlierRun(out, id)) progress("removed " + f + " of an earlier run");
//
// Only what an owlcal run wrote is removed: a folder that holds one of those names (a `report/`
// of the user's, say) with nothing to show that owlcal wrote it is refused, and nothing in it is
// touched.
#include <string>
#include <vector>

namespace owlcal::apps {

// A fresh run id: the UTC time and 32 random bits, "20250314T163605Z-3f9a1c2e".
std::string NewRunId();

// What a calibration run writes at the top of its folder (never datasets/, the recordings):
// results.json, evaluation.json, calibration.yaml, intrinsics.xml, extrinsics.xml,
// robot_corrected.yaml, calibration.md, observations.csv, exports/, figures/, tables/, report/.
const std::vector<std::string>& RunOutputNames();

// The file every calibration run writes first into its folder, holding its run id: it marks the
// folder as owlcal's even when the run was stopped before it wrote anything else.
inline constexpr const char* kRunMarkerName = ".owlcal_run";

// True when `out` shows that owlcal wrote it: the run marker, exports/owlcal_run.json, an
// OpenCV calibration file with owlcal_run_id, or a results.json that is owlcal's (a run_id, or
// inputs.software.name "owlcal").
bool IsOwlcalOutputFolder(const std::string& out);

// Removes every RunOutputNames entry of `out` (and the temporaries a killed atomic write of one
// left there), then writes the run marker with `run_id`; returns the names removed, in
// RunOutputNames order. Creates `out` when missing. Throws naming the path when one cannot be
// removed, and when `out` holds one of those names but is not IsOwlcalOutputFolder (then nothing
// is removed).
std::vector<std::string> RemoveEarlierRun(const std::string& out, const std::string& run_id);

}  // namespace owlcal::apps
