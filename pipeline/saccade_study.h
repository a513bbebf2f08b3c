#pragma once
// The calibrated saccade around a calibration run: what the saccade step's
// controller is given (the fitted head, the servos' fitted slew and lag, the measured delay),
// and the evaluation of the saccade dataset it recorded against the physical bound and the
// course's P loop (evaluation/saccade_eval.h).
//
// `owlcal calibrate` fits first, records the saccade protocol with ControllerCalibration(run),
// then calls AddSaccadeEvaluation; `owlcal fit-datasets` re-evaluates a recorded saccade
// dataset through CalibrateFromDatasets.
//
// The bound of a step of A degrees is A / slew + latency + 1 / fps (fitting/ploop_analysis.h):
// on the virtual Owl with its true slew of the stepped servo and its stream latency
// (CalibratePipelineOptions::truth_*: data/sim truth; docs/conventions.md "Control with
// latency"), else with the slew and exposure delay fitted from the step frames (settling study).
// The notes say which, and give the other where both exist.
#include <string>

#include "evaluation/calibration_run.h"
#include "pipeline/calibrate_pipeline.h"
#include "protocols/runner.h"

namespace owlcal::pipeline {

// The controller's calibration from a run: head (the fit, else the run's nominal head), the
// settling study's fitted slew and lag for the servo it stepped and its exposure delay.
protocols::CalibratedMaps ControllerCalibration(const evaluation::CalibrationRun& run, const std::string& source);

// Reads the saccade dataset's trials into run->steps (controller "saccade"; failed trials are
// rows and warnings) and sets run->saccade: the 10 deg trials when there are any, else those of
// the first amplitude the trials used.
void AddSaccadeEvaluation(const std::string& dataset,
                          const CalibratePipelineOptions& options,
                          evaluation::CalibrationRun* run);

}  // namespace owlcal::pipeline
