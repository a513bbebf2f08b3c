#pragma once
// The fixate step: the closed fixation loop (protocols/fixation.h) on the step's locator, then
// one recorded frame of the settled fixation and a row in fixations.csv (runner.h) with its
// status and reason. FixationFromLoop and MakeStepLocator are shared with the step-response
// step.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

// The fixation loop's options from a fixate or step-response step's loop settings (both eyes,
// FixationOptions' default gain: the step sets its own).
FixationOptions FixationFromLoop(const ClosedLoopSettings& loop, const models::RobotConfig& robot);
// The step's target locator; throws naming the protocol file when `apriltag` has no board target.
std::unique_ptr<TargetLocator> MakeStepLocator(const Protocol& p, Locator kind);

void RunFixateStep(RunContext& run, const Protocol& p, const FixateStep& s);

}  // namespace owlcal::protocols
