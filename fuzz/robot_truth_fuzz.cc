// Robot-truth files (the virtual Owl's hidden robot): any text either loads or throws a
// std::runtime_error naming the file; never a crash, and never a silent fall-back.
#include <cmath>
#include <cstdint>
#include <stdexcept>

#include "fuzz/fuzz_util.h"
#include "robot/robot_file.h"
#include "sim/robot_truth.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  const std::string path = fuzz::AsFile(data, size, ".yaml");
  try {
    const sim::RobotTruth t = sim::LoadRobotTruth(path);
    OWLCAL_FUZZ_ASSERT(robot::ValidateRobotConfig(t.robot).empty());
  } catch (const std::runtime_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
