// owlcal grab --robot HOST [--http-port 8080] --out DIR: save one stereo frame.
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

struct GrabOptions {
  std::string robot;
  std::string robot_file;
  int http_port = 8080;
  std::string out;
  int timeout_ms = 5000;
};

int RunGrab(const GrabOptions& o) {
  const models::RobotConfig robot = robot::RobotConfigOrDefault(o.robot_file);
  const robot::GrabReport r =
      robot::GrabOneFrame(o.robot, o.http_port, robot, o.out, std::chrono::milliseconds(o.timeout_ms));
  std::cout << r.Text();
  return kExitOk;
}

const bool kGrabRegistered = RegisterCommand(
    "grab",
    "Save one stereo frame from http://HOST:PORT/stream/video.mjpeg as DIR/left.png, DIR/right.png\n"
    "(split per the robot file's swap_eyes / mirror) and the raw side-by-side DIR/frame.jpg.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<GrabOptions>();
      cmd->add_option("--robot", o->robot, "robot HOST (a :PORT suffix is the servo port and is ignored here)")
          ->required();
      cmd->add_option("--http-port", o->http_port, "camera stream port")->check(CLI::Range(1, 65535));
      cmd->add_option("--out", o->out, "output folder (created)")->required();
      cmd->add_option("--robot-file", o->robot_file, "robot file (YAML); default: the guide's robot")
          ->check(CLI::ExistingFile);
      cmd->add_option("--timeout-ms", o->timeout_ms, "wait for a frame at most this long [ms]")
          ->check(CLI::Range(1, 60000));
      return [o] { return RunGrab(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
