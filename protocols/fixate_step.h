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
// The fixation locator expects the disc at the size its known radius and the current placement's
// distance give on a nominal lens (FixationDetectorOptions::size_hint_px), when both are known.
std::unique_ptr<TargetLocator> MakeStepLocator(RunContext& run, const Protocol& p, Locator kind);
// The fixation disc's expected radius [px] in the current placement (its target's
// fixation_radius_m x the nominal focal length / the placed distance); 0 when the placement, its
// distance or the target's radius is unknown.
double ExpectedDiscRadiusPx(RunContext& run, const Protocol& p);

void RunFixateStep(RunContext& run, const Protocol& p, const FixateStep& s);

}  // namespace owlcal::protocols
