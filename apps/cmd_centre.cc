// owlcal centre --robot HOST[:PORT] [--robot-file F]: send the robot file's centre pose.
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

struct CentreOptions {
  std::string robot;
  std::string robot_file;
  int timeout_ms = 2000;
};

int RunCentre(const CentreOptions& o) {
  const models::RobotConfig robot = robot::RobotConfigOrDefault(o.robot_file);
  const robot::MoveReport r =
      robot::SendOneCommand(o.robot, robot, robot.Centre(), std::chrono::milliseconds(o.timeout_ms));
  std::cout << "centre pose of " << robot.name << "\n" << r.Text();
  return kExitOk;
}

const bool kCentreRegistered = RegisterCommand(
    "centre",
    "Send the robot's centre pose (centre_us of every servo in the robot file) and print the reply.\n"
    "One connection per run: a one-client server (the course's C server, MRSsocket.c, or\n"
    "`owlcal sim --server c`) exits when this run closes; script moves, waits and centre over one\n"
    "connection with `owlcal shell`.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CentreOptions>();
      cmd->add_option("--robot", o->robot, "robot servo server HOST[:PORT] (port 12345 if omitted; no default host)")
          ->required();
      cmd->add_option("--robot-file", o->robot_file, "robot file (YAML); default: the guide's robot")
          ->check(CLI::ExistingFile);
      cmd->add_option("--timeout-ms", o->timeout_ms, "connect and reply timeout [ms]")->check(CLI::Range(1, 60000));
      return [o] { return RunCentre(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
