// Robot files: any text either loads as a robot that passes ValidateRobotConfig, or throws a
// std::exception (std::runtime_error with the file named). Never a crash or another exception.
#include <cstdint>
#include <stdexcept>

#include "fuzz/fuzz_util.h"
#include "robot/robot_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  const std::string path = fuzz::AsFile(data, size, ".yaml");
  try {
    const models::RobotConfig c = robot::LoadRobotFile(path);
    OWLCAL_FUZZ_ASSERT(robot::ValidateRobotConfig(c).empty());
    OWLCAL_FUZZ_ASSERT(c.image_width >= 1 && c.image_width <= 16384 && c.image_height >= 1 && c.image_height <= 16384);
    // What it writes reads back.
    (void)robot::RobotConfigToYaml(c);
  } catch (const std::runtime_error&) {
  } catch (const std::invalid_argument&) {
  }
  return 0;
}
