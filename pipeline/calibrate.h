#pragma once
// The two calibration workflows as library calls; `owlcal calibrate`, `owlcal fit-datasets`, the
// Monte-Carlo bench and the tests all call these, so they run one algorithm with one set of
// defaults.
//
//   Calibrate(robot, options)   records one dataset per protocol under options.out/datasets/
//                               (after `limits`, on what it learned: pipeline/bring_up.h),
//                               fits, records the protocols that need the fit (the calibrated
//                               saccade) and evaluates everything;
//   FitDatasets(dir, options)   the same fit and evaluations on a folder Calibrate recorded, with
//                               no robot: the robot file and (virtual Owl) the truth come from the
//                               datasets' manifests.
//
// Both return the calibration run the report files are written from (reports/, apps/); neither
// writes a result file. Calibrate(r, o) and FitDatasets(o.out, f) with f.fit = o.fit give the same
// run, value for value: both are FitCalibration then FinishCalibration
// (pipeline/calibrate_pipeline.h) over the same datasets.
//
// Usage:
//   pipeline::CalibrateOptions o;          // exactly what `owlcal calibrate` runs
//   o.out = "out/cal";
//   sim::VirtualOwl owl(vo);
//   evaluation::CalibrationRun run = pipeline::Calibrate(owl, o);
#include <atomic>
#include <functional>
#include <istream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/calibration_run.h"
#include "pipeline/calibrate_pipeline.h"
#include "robot/robot_interface.h"
#include "sim/robot_truth.h"

namespace owlcal::pipeline {

// The fit options `owlcal calibrate` and `owlcal fit-datasets` use by default: the library's
// CalibratePipelineOptions with the lens model chosen by cross-validation (--lens-model auto).
CalibratePipelineOptions DefaultFitOptions();

// What a manifest records about the robot a dataset was recorded on (protocols::RunOptions).
struct RobotRecord {
  std::string spec = "sim";     // "sim" or HOST[:PORT]
  std::string robot_file;       // path of the robot file ("" = built-in)
  std::string robot_file_text;  // its text, so a refit needs no file
  nlohmann::json sim;           // virtual Owl: {"seed", "truth_file", "scene_file"}; null otherwise
};

struct CalibrateOptions {
  std::string out;                                     // the calibration folder; datasets go to out/datasets/NAME
  std::vector<std::string> protocols;                  // names or paths; empty: the standard suite
  CalibratePipelineOptions fit = DefaultFitOptions();  // truth fields are filled by Calibrate
  // The virtual Owl's truth; nullopt: taken from the robot when it is a sim::VirtualOwl.
  std::optional<sim::RobotTruth> truth;
  RobotRecord robot;
  // A real robot: prompt a person for each placement on `input` (default std::cin); false: the
  // protocols' poses are assumed and each dataset says so.
  bool interactive = false;
  std::istream* input = nullptr;
  std::atomic<bool>* stop_flag = nullptr;  // set to stop: the head is parked, datasets closed
  // The protocols after `limits` run on what it measured (pipeline/bring_up.h: the measured stops
  // minus a margin, the directions the image shows); false: on the robot file's configuration.
  bool apply_bring_up = true;
  // The command's own record (command line, seed, ...); Calibrate adds "runs" (per protocol:
  // status, frames, clamped commands, robot clock) and stores it as run.settings and
  // result.inputs["command"].
  nlohmann::json settings = nlohmann::json::object();
  std::function<void(const std::string&)> progress;  // progress lines (may be null)
  bool Check(std::string* why) const;
};

// The virtual Owl's truth as the fit options carry it (true head, latency check's truth, stream
// rate, true slews and latency).
void SetTruth(const sim::RobotTruth& truth, CalibratePipelineOptions* options);

// The virtual Owl's stream and servo dynamics for the latency check's truth column.
evaluation::LatencyTruth LatencyTruthOf(const sim::RobotTruth& truth);

// Runs the workflow above on `robot`. On the virtual Owl the truth is options.truth or, for a
// sim::VirtualOwl, its own. A protocol that did not complete is a warning in the result; a user's stop throws
// std::runtime_error after the head is parked (the datasets so far stay in out/datasets/). Throws
// std::invalid_argument for bad options and protocols::ProtocolError for an unreadable protocol.
evaluation::CalibrationRun Calibrate(robot::RobotInterface& robot, const CalibrateOptions& options);

struct FitDatasetsOptions {
  CalibratePipelineOptions fit = DefaultFitOptions();  // robot config and truth come from the manifests
  std::function<void(const std::string&)> progress;    // progress lines (may be null)
};

// Re-fits the datasets of a folder Calibrate wrote (dir/datasets/*). Throws std::runtime_error
// naming the manifest when the datasets were not recorded on one robot, or a recorded truth
// cannot be rebuilt.
evaluation::CalibrationRun FitDatasets(const std::string& dir, const FitDatasetsOptions& options);

// The virtual Owl's truth a dataset was recorded with, rebuilt from its manifest (the truth file
// named in sim.truth_file, or the built-in one, with the robot file text the manifest kept) and
// checked against the whole truth the manifest recorded; nullopt for a real robot.
std::optional<sim::RobotTruth> TruthFromManifest(const nlohmann::json& manifest, const std::string& path);

}  // namespace owlcal::pipeline
