// Protocol files: any text either parses into at most kMaxPlanSteps steps whose pulse-width
// quantities are bounded, or throws ProtocolError naming the file. Never bad_alloc or a crash.
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "protocols/protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  try {
    const protocols::Protocol p = protocols::ParseProtocolYaml(fuzz::Text(data, size), "fuzz.yaml");
    OWLCAL_FUZZ_ASSERT(int64_t(p.steps.size()) <= protocols::kMaxPlanSteps);
    for (const protocols::Step& s : p.steps) {
      if (const auto* sweep = std::get_if<protocols::SweepStep>(&s.params))
        OWLCAL_FUZZ_ASSERT(sweep->step_us >= 1 && sweep->step_us <= protocols::kMaxPulseUs);
      if (const auto* latency = std::get_if<protocols::LatencyStep>(&s.params))
        OWLCAL_FUZZ_ASSERT(latency->amplitude_us >= 1 && latency->amplitude_us <= protocols::kMaxPulseUs);
      (void)protocols::CheckStepForRobot(s, models::DefaultRobotConfig());
    }
  } catch (const protocols::ProtocolError&) {
  } catch (const std::runtime_error&) {  // target definitions (calib/target_file)
  }
  return 0;
}
