#pragma once
// The limits step: for each listed servo, searches both ends from the centre pose
// (protocols/limits_search.h) and writes limits.csv (runner.h). An end that could not be
// measured fails the step after all rows are written.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunLimitsStep(RunContext& run, const LimitsStep& s);

}  // namespace owlcal::protocols
