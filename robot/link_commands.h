#pragma once
// The work behind `owlcal move`, `owlcal centre` and `owlcal grab` (apps/cmd_*.cc), as
// library functions so tests can drive them against the loopback servers.
//
// A robot is always given explicitly as HOST[:PORT] (servo port, default 12345); nothing
// here defaults to the real robot's address.
#include <chrono>
#include <string>

#include "models/robot_config.h"
#include "robot/robot_interface.h"

namespace owlcal::robot {

// The robot file at `path`, or the guide's robot (models::DefaultRobotConfig()) for "".
models::RobotConfig RobotConfigOrDefault(const std::string& path);

struct MoveReport {
  std::string robot;          // "host:port"
  PwmVector requested{};      // what the user asked for
  ServoReply reply;           // what was sent after the guard, and the server's answer
  std::string clamp_message;  // "" or the guard's line naming every clamp
  // Human-readable lines: what was sent, any clamp, the reply.
  std::string Text() const;
};

// Connects to robot_hostport, sends one command through the limits guard, waits for the
// reply and closes the session. Throws std::runtime_error (naming host:port) when the robot
// cannot be reached or does not answer within `timeout`; std::invalid_argument for a bad
// HOST[:PORT].
MoveReport SendOneCommand(const std::string& robot_hostport,
                          const models::RobotConfig& robot,
                          const PwmVector& pwm_us,
                          std::chrono::milliseconds timeout = std::chrono::milliseconds(2000));

struct GrabReport {
  std::string left_png, right_png, frame_jpg;  // written paths
  int width = 0, height = 0;                   // of the side-by-side frame
  std::string Text() const;
};

// Reads one frame from http://HOST:http_port/stream/video.mjpeg (HOST from robot_host,
// which may carry a servo port that is ignored here), splits it per the robot file
// (swap_eyes, mirror) and writes out_dir/left.png, right.png and the raw frame.jpg
// (out_dir is created). Throws std::runtime_error naming the URL or path on failure.
GrabReport GrabOneFrame(const std::string& robot_host,
                        int http_port,
                        const models::RobotConfig& robot,
                        const std::string& out_dir,
                        std::chrono::milliseconds timeout = std::chrono::milliseconds(5000));

}  // namespace owlcal::robot
