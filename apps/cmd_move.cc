// owlcal move --robot HOST[:PORT] Rx Ry Lx Ly Neck: one servo command through the limits guard.
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

struct MoveOptions {
  std::string robot;
  std::string robot_file;
  std::vector<int> pwm_us;
  int timeout_ms = 2000;
};

int RunMove(const MoveOptions& o) {
  if (o.pwm_us.size() != models::kNumServos) throw UsageError("expected 5 pulse widths: Rx Ry Lx Ly Neck");
  const models::RobotConfig robot = robot::RobotConfigOrDefault(o.robot_file);
  models::PwmVector pwm;
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = o.pwm_us[i];
  const robot::MoveReport r = robot::SendOneCommand(o.robot, robot, pwm, std::chrono::milliseconds(o.timeout_ms));
  std::cout << r.Text();
  return kExitOk;
}

const bool kRegistered = RegisterCommand(
    "move",
    "Send one servo command (pulse widths in us, wire order Rx Ry Lx Ly Neck), clamped to the\n"
    "robot file's limits; prints what was sent, any clamp and the server's reply.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<MoveOptions>();
      cmd->add_option("--robot", o->robot, "robot servo server HOST[:PORT] (port 12345 if omitted; no default host)")
          ->required();
      cmd->add_option("--robot-file", o->robot_file, "robot file (YAML) with the limits; default: the guide's robot")
          ->check(CLI::ExistingFile);
      cmd->add_option("--timeout-ms", o->timeout_ms, "connect and reply timeout [ms]")->check(CLI::Range(1, 60000));
      cmd->add_option("pwm", o->pwm_us, "Rx Ry Lx Ly Neck [us]")->expected(5)->required();
      return [o] { return RunMove(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
