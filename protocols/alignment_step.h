#pragma once
// The alignment step: at the centre pose, the roll and the vertical and horizontal offsets
// between the eyes, from the protocol's chessboard when both eyes see it, else by phase
// correlation of the whole images (alignment.csv, runner.h).
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunAlignmentStep(RunContext& run, const Protocol& p, const AlignmentStep& s);

}  // namespace owlcal::protocols
