// owlcal move --robot HOST[:PORT] Rx Ry Lx Ly Neck: one servo command through the limits guard.
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "io/strict_number.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

struct MoveOptions {
  std::string robot;
  std::string robot_file;
  std::vector<std::string> pwm_us;  // parsed strictly: '' and 0x600 are not pulse widths
  int timeout_ms = 2000;
};

int RunMove(const MoveOptions& o) {
  if (o.pwm_us.size() != models::kNumServos) throw UsageError("expected 5 pulse widths: Rx Ry Lx Ly Neck");
  const models::RobotConfig robot = robot::RobotConfigOrDefault(o.robot_file);
  models::PwmVector pwm;
  static constexpr const char* kNames[models::kNumServos] = {"Rx", "Ry", "Lx", "Ly", "Neck"};
  for (int i = 0; i < models::kNumServos; ++i) {
    // Decimal digits only; the packet carries four digits, the limits guard then clamps.
    const std::string why = io::CheckInt(o.pwm_us[i], 0, 9999, &pwm[i]);
    if (!why.empty())
      throw UsageError(std::string("pulse width ") + kNames[i] + " " + why + " (decimal us, e.g. 1500)");
  }
  const robot::MoveReport r = robot::SendOneCommand(o.robot, robot, pwm, std::chrono::milliseconds(o.timeout_ms));
  std::cout << r.Text();
  return kExitOk;
}

const bool kMoveRegistered = RegisterCommand(
    "move",
    "Send one servo command (pulse widths in us, wire order Rx Ry Lx Ly Neck), clamped to the\n"
    "robot file's limits; prints what was sent, any clamp and the server's reply.\n"
    "One connection per run: connect, send, close. A one-client server (the course's C server,\n"
    "MRSsocket.c, or `owlcal sim --server c`) exits when this run closes, so a second move or\n"
    "centre is refused; send several commands over one connection with `owlcal shell`.",
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
