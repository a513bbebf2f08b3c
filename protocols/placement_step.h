#pragma once
// The place-target step: puts a target where the protocol says. The virtual Owl moves it in
// its scene; on a real robot an interactive run prompts a person (a number answered is the
// measured distance in mm), otherwise the placement is assumed. placements.csv records it.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunPlaceTargetStep(RunContext& run, const Protocol& p, const PlaceTargetStep& s);

}  // namespace owlcal::protocols
