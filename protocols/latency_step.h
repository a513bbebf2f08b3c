#pragma once
// The latency step: steps one servo about the centre and counts the time from the command to
// the first frame whose image moved by a fifth of the expected shift (latency.csv, runner.h).
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunLatencyStep(RunContext& run, const LatencyStep& s);

}  // namespace owlcal::protocols
