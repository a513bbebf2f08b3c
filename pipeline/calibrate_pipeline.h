#pragma once
// Everything `owlcal calibrate` does after recording, as one library call: from the recorded
// datasets (one folder per protocol, protocols/dataset.h) to the calibration run the report
// files are written from (evaluation/calibration_run.h). `owlcal calibrate` records and then calls
// it; `owlcal fit-datasets DIR` calls it on a recorded calibrate folder with no robot, and with
// the same options reproduces every results.json value and sigma.
//
// It sits above protocols/ (the dataset readers) and fitting/ (the fits and evaluations); it
// moves nothing and writes nothing (apps/ write the files).
//
// Steps, each on the datasets present (a protocol that did not run is skipped, and said so), one
// file each (pipeline/calibrate_stages.h: stage_lens_stereo, stage_head, stage_truth,
// stage_ranging, stage_controller):
//   1. intrinsics + stereo from `intrinsics` (eyes moving: each eye's intrinsics only) and
//      `stereo` (eyes fixed: left and right paired), the lens model chosen by cross-validation
//      over those views, with the physical sanity of the rig;
//   2. the head (servo maps, eye centres, intrinsics refined) from `servo_sweep`, one board per
//      placement; with the sweep's tag sheets also the fit fusing them, and the tag study
//      (pipeline/tag_study.h, diagnostics.tags);
//   3. the truth in the fit's gauge (virtual Owl only: CalibratePipelineOptions::truth);
//   4. evaluations: ranging from `vergence` (every fixation a row with its status), the gain
//      study at the delay `latency` measured, step responses from `step_response`, limits from
//      `limits`, calibrated saccades from `saccade` (pipeline/saccade_study.h);
//   5. the checks against references (evaluation/reference_checks.h, results.json
//      diagnostics.reference_checks): latency from `latency` (truth on the virtual Owl), the
//      alignment from `alignment` with its verdict, the field of view against the datasheet.
// Every option goes into result.inputs["pipeline"] and the datasets into result.inputs["datasets"].
#include <array>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/calibration_run.h"
#include "evaluation/reference_checks.h"
#include "fitting/head_fit.h"
#include "fitting/lens_model_choice.h"
#include "fitting/stereo_fit.h"
#include "models/head_model.h"
#include "models/robot_config.h"
#include "pipeline/bring_up.h"

namespace owlcal::pipeline {

struct CalibratePipelineOptions {
  models::RobotConfig config = models::DefaultRobotConfig();
  // What the bring-up learned from the limits dataset when the protocols after it ran on it
  // (pipeline/bring_up.h; then config is bring_up->learned): its findings lead the warnings (after
  // any dataset skipped), it is diagnostics.bring_up, and the limits are compared with the robot
  // file's (bring_up->file).
  std::optional<BringUp> bring_up;
  // The virtual Owl's true head (as the robot truth gives it, not yet in the fit's gauge):
  // true fixation distances and the truth columns. nullopt on a real robot.
  std::optional<models::HeadModel> truth;
  // The virtual Owl's stream and servo dynamics, for the latency check's truth column (the
  // reading the truth predicts per trial, evaluation/reference_checks.h). nullopt on a real robot.
  std::optional<evaluation::LatencyTruth> latency_truth;
  double fps = 30.0;  // stream frame rate (latency in frames, gain study)
  // The virtual Owl's true servo slew [deg/s] and stream latency (exposure to arrival) [s]: the
  // saccade's physical bound (pipeline/saccade_study.h). 0: unknown (a real robot), then the
  // bound uses the slew and exposure delay fitted from the step frames.
  std::array<double, models::kNumServos> truth_slew_deg_per_s{};
  double truth_latency_s = 0;
  int default_delay_frames = 3;  // loop delay when no latency dataset measured it
  fitting::StereoFitOptions stereo = CalibrateStereoFitOptions();
  // The lens model of both eyes (and so of the head fit), chosen by cross-validation over the
  // intrinsics and stereo views (fitting/lens_model_choice.h); Off() keeps stereo.intrinsics.model.
  // Off here; pipeline::DefaultFitOptions(), what calibrate and fit-datasets run, turns it on.
  fitting::LensModelChoiceOptions lens_choice = fitting::LensModelChoiceOptions::Off();
  fitting::HeadFitOptions head = CalibrateHeadFitOptions();
  // Every sigma factor, floor and prior below, and why it has its value: docs/uncertainty.md.
  // The stereo fit's intrinsics covariance (x head.measured_sigma_factor^2) as a prior on the
  // head's intrinsics when the head refines them and sets no prior of its own: the sweep alone
  // pins the common scale of focal lengths, servo scales and IPD only weakly.
  bool head_prior_from_stereo = true;
  // The head result is the fit fusing the servo sweep's tag sheets with the chessboard; false: the
  // chessboard's alone. Both run when the sweep saw tags; diagnostics.tags compares them.
  bool fuse_tags = true;
  // The fused fit whitens the tag corners by this many times their measured sigma: a static sheet
  // repeats its corners' errors in every view.
  double tag_sigma_factor = 3.0;
  // The fused fit's intrinsics covariance floor: the stereo fit's covariance times this squared
  // (1: the chessboard fit's floor; 0: none).
  double fused_floor_scale = 0.4;
  // The fused fit's focal scale (mean log focal length) and principal points no more certain than
  // the stereo fit's: the static sheets move them more than their residuals show.
  bool fused_pinhole_floor = true;
  // The fused fit's pan zero no more certain than the chessboard fit's (the fits then run one
  // after the other): the tags see the eye centres' depths no better.
  bool fused_pan_zero_floor = true;
  // Distances of the theoretical ranging-error curve [m].
  double theory_min_m = 0.2, theory_max_m = 2.0, theory_step_m = 0.05;
  // Progress lines (may be null).
  std::function<void(const std::string&)> progress;
  // Warnings the user must see even when progress lines are off (a dataset no step reads); each
  // is also in result.warnings (may be null).
  std::function<void(const std::string&)> warning;

  // The head-fit options `owlcal calibrate` uses (why each: calibrate_pipeline.cc).
  static fitting::HeadFitOptions CalibrateHeadFitOptions();
  // The stereo-fit options `owlcal calibrate` uses (the board's bow fitted).
  static fitting::StereoFitOptions CalibrateStereoFitOptions();
  bool Check(std::string* why) const;
  // Every option above but `truth`, `progress` and `warning`, for results.json's inputs.
  nlohmann::json ToJson() const;
};

// `--lens-model` of calibrate and fit-datasets: "auto" (cross-validation, the default), "opencv5"
// or "opencv8" (that model, no cross-validation). False (and why) for another value.
bool SetLensModel(const std::string& value, CalibratePipelineOptions* options, std::string* why);

// Runs the steps above on `datasets` (protocol name -> dataset folder; a dataset of a protocol
// the pipeline does not know is skipped with a warning naming it, the first of result.warnings
// and said through options.warning). Failures of a fit are warnings in the result, never a
// throw; unreadable dataset files throw std::runtime_error naming path:line:column.
evaluation::CalibrationRun CalibrateFromDatasets(const std::map<std::string, std::string>& datasets,
                                                 const CalibratePipelineOptions& options);

// CalibrateFromDatasets in the two parts pipeline::Calibrate records between: FitCalibration runs
// steps 1-4 up to the saccade (everything the calibrated controller needs; it reads no saccade
// dataset), FinishCalibration the saccade and limits evaluations, the checks against references
// and the inputs. CalibrateFromDatasets(d, o) is FitCalibration(d, o) then FinishCalibration(d, o).
evaluation::CalibrationRun FitCalibration(const std::map<std::string, std::string>& datasets,
                                          const CalibratePipelineOptions& options);

// FitCalibration in two parts: FitGeometry (the bring-up's findings, lens, stereo, head, truth
// comparison and tag study) reads only the datasets GeometryDatasetNames() lists, so
// pipeline::Calibrate runs it while the protocols after those record; FitEvaluations then adds
// the unknown-dataset warnings (first of result.warnings), resolution, ranging and steps.
// FitCalibration(d, o) is FitGeometry(d, o) then FitEvaluations(d, o).
const std::set<std::string>& GeometryDatasetNames();
evaluation::CalibrationRun FitGeometry(const std::map<std::string, std::string>& datasets,
                                       const CalibratePipelineOptions& options);
void FitEvaluations(const std::map<std::string, std::string>& datasets,
                    const CalibratePipelineOptions& options,
                    evaluation::CalibrationRun* run);
void FinishCalibration(const std::map<std::string, std::string>& datasets,
                       const CalibratePipelineOptions& options,
                       evaluation::CalibrationRun* run);

// The trials of a step-response (or saccade) dataset: one trace per trial with its status and
// stepinfo (2 % band); trials without usable frames are rows with their status, no metrics.
std::vector<fitting::StepTrace> ReadStepTraces(const std::string& dataset);

// The datasets of a recorded calibrate folder: every DIR/datasets/*/ with a manifest, by the
// name of the protocol its manifest records. Throws NoDatasetsError when there are none, a
// manifest names no single protocol, or two datasets are of one protocol.
struct NoDatasetsError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
std::map<std::string, std::string> FindDatasets(const std::string& calibration_dir);

// The robot configuration a dataset was recorded with (manifest.json robot.config), naming the
// field on a malformed manifest.
models::RobotConfig RobotConfigFromManifest(const nlohmann::json& manifest, const std::string& path);

}  // namespace owlcal::pipeline
