#pragma once
// The step-response step: per gain, amplitude and trial, fixate one eye's target, step the
// servo away by the amplitude (alternating direction), run the loop for a fixed number of frames
// logging every frame (step_response.csv) and the trial's outcome (step_trials.csv), and go
// back to the fixation pose.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunStepResponseStep(RunContext& run, const Protocol& p, const StepResponseStep& s);

}  // namespace owlcal::protocols
