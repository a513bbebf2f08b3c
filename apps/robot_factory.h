#pragma once
// Makes the robot a protocol runs on from its command-line spec:
//   "sim"         the in-process virtual Owl (sim::VirtualOwl) on a virtual clock, from
//                 options.truth_file (empty = built-in default robot) and options.seed;
//   "HOST[:PORT]" a real (or served virtual) Owl over TCP + HTTP (robot::OwlLink), servo port
//                 PORT (default 12345), stream on options.http_port (default 8080), limits
//                 from options.robot_file (empty = the guide's robot).
// There is no default address: an empty spec is an error. Throws std::invalid_argument for a
// bad spec and std::runtime_error (naming the file) for unreadable files.
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "robot/robot_interface.h"

namespace owlcal::apps {

struct RobotFactoryOptions {
  std::string robot_file;  // robot file (limits, centres); "" = built-in
  std::string truth_file;  // sim only: robot-truth file; "" = built-in default truth
  std::string scene_file;  // sim only
  uint64_t seed = 1;       // sim only
  int http_port = 8080;    // real robot: MJPEG stream port
  // The limits, centres and stream layout to use instead of robot_file's (owlcal jog opens the
  // limits to its envelope; the re-validation runs on the file it wrote).
  std::optional<models::RobotConfig> robot_config;
  // Real robot: clamps and link events (a lost and re-opened servo connection). Default:
  // stderr, prefixed "owlcal: ", so a reconnect is never silent.
  std::function<void(const std::string&)> log;
};

std::unique_ptr<robot::RobotInterface> MakeRobot(const std::string& spec, const RobotFactoryOptions& options);

}  // namespace owlcal::apps
