#pragma once
// The stages of pipeline::FitCalibration and FinishCalibration (pipeline/calibrate_pipeline.h),
// one file each: each reads the datasets it needs and hands its typed result to the next.
// Internal to pipeline/: the workflow's entry points are in calibrate_pipeline.h.
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "calib/observation.h"
#include "evaluation/calibration_run.h"
#include "evaluation/ranging_eval.h"
#include "fitting/head_fit.h"
#include "fitting/servo_resolution_fit.h"
#include "fitting/stereo_fit.h"
#include "models/head_model.h"
#include "pipeline/calibrate_pipeline.h"

namespace owlcal::pipeline::stages {

// What every stage reads: the datasets by protocol name and calibrate's options.
struct Inputs {
  const std::map<std::string, std::string>& datasets;
  const CalibratePipelineOptions& options;
  // The folder of protocol `name`'s dataset; empty when it did not run.
  std::string Dataset(const char* name) const;
  // A progress line through options.progress (when set).
  void Progress(const std::string& line) const;
};

// A dataset's observations.csv; empty when the dataset or the file is missing.
std::vector<calib::CornerObservation> ReadObservations(const std::string& dataset);

// 1) Intrinsics and stereo from the intrinsics and stereo datasets, the lens model chosen by
// cross-validation, the rig's physical sanity; into run->result. nullopt without views of both eyes.
std::optional<fitting::StereoFit> FitLensAndStereo(const Inputs& in, evaluation::CalibrationRun* run);

// 2) The head from the servo sweep: what the truth and the tag study need of it.
struct HeadStage {
  models::HeadModel initial;  // the nominal head with the stereo fit's intrinsics
  bool neck_moved = false;    // the sweep moved the neck off its centre
  std::vector<calib::View> sweep_views;
  fitting::HeadFitOptions options;  // with the sweep's noise classes and tag sizes
  std::optional<fitting::HeadFit> with_tags, without_tags;
};
HeadStage FitHeadFromSweep(const Inputs& in,
                           const std::optional<fitting::StereoFit>& stereo,
                           evaluation::CalibrationRun* run);

// 3) The truth in the fit's gauge (virtual Owl: options.truth), then the tag study.
void CompareWithTruth(const Inputs& in, const HeadStage& head, evaluation::CalibrationRun* run);
void AddTagStudy(const Inputs& in, const HeadStage& head, evaluation::CalibrationRun* run);

// 4) Evaluations: the servos' PWM step and dead band, ranging, the gain study, step responses and
// the loop model; FinishCalibration's limits and reference checks.
void EvaluateResolutionAndRanging(const Inputs& in, evaluation::CalibrationRun* run);
void EvaluateSteps(const Inputs& in, evaluation::CalibrationRun* run);
void EvaluateLimits(const Inputs& in, evaluation::CalibrationRun* run);
void AddReferenceChecks(const Inputs& in, evaluation::CalibrationRun* run);

}  // namespace owlcal::pipeline::stages
