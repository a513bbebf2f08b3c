#pragma once
// What `owlcal calibrate` and `owlcal fit-datasets` share after the pipeline: progress lines and
// the calibration folder's files (results.json, evaluation.json, calibration.yaml, the course's
// xml, exports/, figures/, tables/, report/index.html).
#include <chrono>
#include <string>
#include <utility>

#include <nlohmann/json.hpp>

#include "evaluation/calibration_run.h"
#include "evaluation/reference_checks.h"
#include "sim/robot_truth.h"

namespace CLI {
class App;
}  // namespace CLI

namespace owlcal::apps {

// "[NAME 12.3 s] message" lines on stdout (nothing when quiet).
class Progress {
 public:
  Progress(std::string name, bool quiet)
      : name_(std::move(name)), quiet_(quiet), t0_(std::chrono::steady_clock::now()) {}
  void operator()(const std::string& msg) const;

 private:
  std::string name_;
  bool quiet_;
  std::chrono::steady_clock::time_point t0_;
};

// Prints "warning: MESSAGE" on stderr, with --quiet too (CalibratePipelineOptions::warning).
void PrintWarning(const std::string& message);

// The software that made a result: {"name": "owlcal", "version", "git"} (git describe at
// configure time, "unknown" without a checkout).
nlohmann::json SoftwareInputs();

// Stamps a result with the software that made it (software_version, inputs.software) and its
// run id (apps/output_folder.h StartRun).
void StampRun(const std::string& run_id, fitting::CalibrationResult* result);

// Stamps run->result (StampRun with the run id from StartRun) and writes the calibration folder
// `out`; draw = run gnuplot. On the virtual Owl, prints the comparison with the truth.
void WriteCalibrationFolder(evaluation::CalibrationRun* run,
                            const std::string& run_id,
                            const std::string& out,
                            bool draw,
                            const Progress& progress);

// The options calibrate and fit-datasets share after the pipeline: --no-figures, --quiet and
// --lens-model (auto|opencv5|opencv8).
void AddCalibrationOutputOptions(CLI::App* cmd, bool* no_figures, bool* quiet, std::string* lens_model);

}  // namespace owlcal::apps
