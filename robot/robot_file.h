#pragma once
// Robot file (YAML) <-> models::RobotConfig: one robot's servo limits, centres, directions
// and nominal scale, its design IPD and how its camera stream is laid out.
//
//   name: guide-owl
//   ipd_mm: 65.0
//   image: {width: 640, height: 480, swap_eyes: false, mirror: false}
//   servos:                       # wire order Rx Ry Lx Ly Neck; all five required
//     Rx:   {min_us: 1200, max_us: 1890, centre_us: 1545, direction: 1,  deg_per_us: 0.113}
//     Ry:   {min_us: 1120, max_us: 2000, centre_us: 1530, direction: 1,  deg_per_us: 0.113}
//     Lx:   {min_us: 1180, max_us: 1850, centre_us: 1545, direction: 1,  deg_per_us: 0.113}
//     Ly:   {min_us: 1180, max_us: 2000, centre_us: 1580, direction: -1, deg_per_us: 0.113}
//     Neck: {min_us: 1100, max_us: 1950, centre_us: 1530, direction: -1, deg_per_us: 0.113}
//
// Units: pulse widths in us (four digits, 1000..9999, as the packet requires), ipd in mm,
// deg_per_us in degrees per us. `direction` is the sign of the joint angle per increasing
// PWM (models/robot_config.h: +1 right / up). image.mirror is RobotConfig::mirror_stream.
// Optional: name (default: the file's stem), ipd_mm (65), image (640x480, no swap or mirror),
// deg_per_us (0.113). Unknown keys are errors (they are usually typos).
//
// Validation, each error naming the file, field and value, e.g.
//   "robots/x.yaml: servos.Rx.min_us = 2100 is above max_us 1890"
// checks: min_us < centre_us < max_us, every pulse width four digits, direction +1 or -1,
// deg_per_us > 0, ipd_mm > 0, image width and height each in 16..8192 px (one eye; the
// stream is twice as wide). Values are strict numbers (io/strict_number.h: no nan, inf or
// hex); a key given twice, a list where a value belongs and unknown keys are errors naming
// the file, line and field (io/yaml_fields.h), e.g.
//   "robots/x.yaml:7: servos.Neck.min_us = 'abc' is not an integer".
// Errors throw std::runtime_error.
#include <string>

#include <yaml-cpp/yaml.h>

#include "models/robot_config.h"

namespace owlcal::robot {

// Bounds of one eye's image in a robot file [px]. Frames are checked against the robot file's
// size before they are decoded (robot/mjpeg_client.h), so these also bound decoding memory.
inline constexpr int kMinImageSide = 16;
inline constexpr int kMaxImageSide = 8192;

// Reads and validates a robot file. Throws std::runtime_error naming the path on any error.
models::RobotConfig LoadRobotFile(const std::string& path);

// The same from a parsed node; `source_name` prefixes every error message.
models::RobotConfig RobotConfigFromYaml(const YAML::Node& root, const std::string& source_name);

// Checks a config as LoadRobotFile does; "" if valid, else the first error (without prefix).
std::string ValidateRobotConfig(const models::RobotConfig& config);

// The config as YAML text in the format above.
std::string RobotConfigToYaml(const models::RobotConfig& config);

// Writes the file (validated first). Throws std::runtime_error naming the path on failure.
void SaveRobotFile(const models::RobotConfig& config, const std::string& path);

}  // namespace owlcal::robot
