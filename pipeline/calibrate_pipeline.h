#pragma once
// Everything `owlcal calibrate` does after recording, as one library call: from the recorded
// datasets (one folder per protocol, protocols/dataset.h) to the calibration run the report
// files are written from (fitting/calibration_run.h). `owlcal calibrate` records and then calls
// it; `owlcal fit-datasets DIR` calls it on a recorded calibrate folder with no robot, and with
// the same options reproduces every results.json value and sigma.
//
// It sits above protocols/ (the dataset readers) and fitting/ (the fits and evaluations); it
// moves nothing and writes nothing (apps/ write the files).
//
// Steps, each on the datasets present (a protocol that did not run is skipped, and said so):
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
//   5. the checks against references (fitting/reference_checks.h, results.json
//      diagnostics.reference_checks): latency from `latency` (truth on the virtual Owl), the
//      alignment from `alignment` with its verdict, the field of view against the datasheet.
// Every option goes into result.inputs["pipeline"] and the datasets into result.inputs["datasets"].
#include <array>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fitting/calibration_run.h"
#include "fitting/head_fit.h"
#include "fitting/lens_model_choice.h"
#include "fitting/reference_checks.h"
#include "fitting/stereo_fit.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::pipeline {

struct CalibratePipelineOptions {
  models::RobotConfig config = models::DefaultRobotConfig();
  // The virtual Owl's true head (as the robot truth gives it, not yet in the fit's gauge):
  // true fixation distances and the truth columns. nullopt on a real robot.
  std::optional<models::HeadModel> truth;
  // The virtual Owl's stream and servo dynamics, for the latency check's truth column (the
  // reading the truth predicts per trial, fitting/reference_checks.h). nullopt on a real robot.
  std::optional<fitting::LatencyTruth> latency_truth;
  double fps = 30.0;                  // stream frame rate (latency in frames, gain study)
  // The virtual Owl's true servo slew [deg/s] and stream latency (exposure to arrival) [s]: the
  // saccade's physical bound (pipeline/saccade_study.h). 0: unknown (a real robot), then the
  // bound uses the slew and exposure delay fitted from the step frames.
  std::array<double, models::kNumServos> truth_slew_deg_per_s{};
  double truth_latency_s = 0;
  int default_delay_frames = 3;       // loop delay when no latency dataset measured it
  fitting::StereoFitOptions stereo = CalibrateStereoFitOptions();
  // The lens model of both eyes (and so of the head fit): chosen by cross-validation over the
  // intrinsics and stereo views (fitting/lens_model_choice.h); enabled = false keeps
  // stereo.intrinsics.model (the library default; calibrate and fit-datasets turn it on with
  // --lens-model auto).
  fitting::LensModelChoiceOptions lens_choice = fitting::LensModelChoiceOptions::Off();
  fitting::HeadFitOptions head = CalibrateHeadFitOptions();
  // When the head refines the intrinsics (head.fit_intrinsics) and head sets no prior of its own:
  // keep the stereo fit's knowledge of each eye's intrinsics as a Gaussian prior on them (its
  // covariance block, widened head.measured_sigma_factor x like the head's own corners;
  // undetermined parameters get no prior). Without it the sweep alone pins the common scale of
  // the focal lengths, servo scales and IPD weakly, and the fit slid along it (calibrate_pipeline.cc).
  bool head_prior_from_stereo = true;
  // The head result from the fit that fuses the servo sweep's tag sheets with the chessboard
  // (each kind whitened by its own measured noise), instead of the chessboard's alone. Both
  // fits run when the sweep saw tags, and diagnostics.tags compares them (pipeline/tag_study.h).
  // History: fused as points, the tag corners (0.015 px farther from the principal point than
  // their projections: the lens bends the tags' edges) pulled the focal lengths +0.06 % and the
  // servo scales -0.04 %; each tag corner is now compared with the detector's straight-edge
  // corner (HeadFitOptions::tag_size_of_board, fitting/tag_edge_corner.h). Even so the sweep's
  // static sheets move three things by more than their residuals show: the split of the common
  // scale between the focal lengths and the servo scales, the principal points and the pan zero.
  // The fused fit keeps those no more certain than the chessboard's knowledge of them
  // (fused_pinhole_floor, fused_pan_zero_floor) and a share of the stereo fit's intrinsics floor
  // (fused_floor_scale). So chosen on 30 robots of the prior (bench/robot_prior_mc_bench.cc 30
  // 101, refits of the kept sets) and checked on 30 others (30 1): see docs/conventions.md.
  bool fuse_tags = true;
  // The fused fit whitens the tag corners by this many times their measured sigma
  // (HeadFitOptions::sigma_factor_of_class, for the tag sheets' class). Over 12 robots of the prior
  // (bench/robot_prior_mc_bench.cc 12 1) at 1 the fused fit's errors at the servo ends were 38 % within 1 sigma and 85
  // % within 3, and all five servo scales 1-6 sigma low together with the focal lengths +0.3-2.2 sigma high: the tags
  // set the split of the common scale between them. At 3: 62.5 % / 100 %, the servo maps 72.9 / 99.3 % (the
  // chessboard's alone 69.2 / 99.2 and 69.4 / 97.6). The tag detector is not the cause:
  // tests/sim/tag_corner_bias_test.cc.
  double tag_sigma_factor = 3.0;
  // The fused fit's floor of the intrinsics covariance (and its carry to the servo maps,
  // HeadFitOptions::intrinsics_covariance_floor): the stereo fit's covariance times this squared.
  // 1: the chessboard fit's floor; 0: none. Over robots 101-130 of the prior (tag_sigma_factor 3)
  // without the two floors below the fused lens errors were 82.8 % within 1 sigma at 1 and 53.5 %
  // at 0; at 0.6 the servo maps were 70.7 / 98.75 % within 1 / 3 sigma (prior-120's five servo
  // scales 2.2-2.7 sigma low, its focal lengths 2.3 high). With both floors: at 0.6 the servo maps
  // 75.8 % and servo ends 74.7 % within 1 sigma (too wide), at 0.4 every fused group within
  // 68 +- 5 % and >= 99 % (head geometry 69.6 / 100, lens 68.7 / 99.81, servo maps 72.1 / 99.44,
  // servo ends 72.0 / 100), at 0 the lens 58.0 / 97.22.
  double fused_floor_scale = 0.4;
  // The fused fit's focal scale (the mean of log fx, log fy over both eyes) no more certain than
  // the stereo fit's, the shortfall carried to what moves with it (HeadFitOptions::
  // focal_scale_sigma_floor: the servo scales above all), and each principal point's (cx, cy) no
  // more certain than the stereo fit's (principal_point_covariance_floor, that block alone). Over
  // robots 101-130 the fused fit moved the focal lengths and the servo scales up and down together
  // by up to 2.7 of its sigmas (prior-120) and the principal points by 1.6-1.7 RMS(z) at
  // fused_floor_scale 0.4; the chessboard fit's were 0.9-1.2.
  bool fused_pinhole_floor = true;
  // The fused fit's pan zero no more certain than the chessboard fit's (HeadFitOptions::
  // pan_zero_sigma_floor_deg; the two fits then run one after the other). Over robots 101-130 the
  // fused pan centres differed from the chessboard's by less than 0.8 of the chessboard's sigma
  // while their own sigmas were 0.5-0.9 of it (median 0.78): both stand on the same eye-centre
  // depths; both pans' centres were 3.1-3.3 sigma off together on prior-121 and prior-126.
  bool fused_pan_zero_floor = true;
  // Distances of the theoretical ranging-error curve [m].
  double theory_min_m = 0.2, theory_max_m = 2.0, theory_step_m = 0.05;
  // Progress lines (may be null).
  std::function<void(const std::string&)> progress;

  // The head-fit options `owlcal calibrate` uses (why each: calibrate_pipeline.cc).
  static fitting::HeadFitOptions CalibrateHeadFitOptions();
  // The stereo-fit options `owlcal calibrate` uses (the board's bow fitted).
  static fitting::StereoFitOptions CalibrateStereoFitOptions();
  bool Check(std::string* why) const;
  // Every option above but `truth` and `progress`, for results.json's inputs.
  nlohmann::json ToJson() const;
};

// `--lens-model` of calibrate and fit-datasets: "auto" (cross-validation, the default), "opencv5"
// or "opencv8" (that model, no cross-validation). False (and why) for another value.
bool SetLensModel(const std::string& value, CalibratePipelineOptions* options, std::string* why);

// Runs the steps above on `datasets` (protocol name -> dataset folder; names the pipeline does
// not know are listed in a warning). Failures of a fit are warnings in the result, never a
// throw; unreadable dataset files throw std::runtime_error naming path:line:column.
fitting::CalibrationRun CalibrateFromDatasets(const std::map<std::string, std::string>& datasets,
                                              const CalibratePipelineOptions& options);

// The trials of a step-response (or saccade) dataset: one trace per trial with its status and
// stepinfo (2 % band); trials without usable frames are rows with their status, no metrics.
std::vector<fitting::StepTrace> ReadStepTraces(const std::string& dataset);

// The datasets of a recorded calibrate folder: every DIR/datasets/*/ with a manifest, by the
// name of the protocol its manifest records. Throws when there are none, or two datasets of
// one protocol.
std::map<std::string, std::string> FindDatasets(const std::string& calibration_dir);

// The robot configuration a dataset was recorded with (manifest.json robot.config), naming the
// field on a malformed manifest.
models::RobotConfig RobotConfigFromManifest(const nlohmann::json& manifest, const std::string& path);

}  // namespace owlcal::pipeline
