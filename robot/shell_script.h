#pragma once
// `owlcal shell`: several servo commands over ONE connection, so a student whose
// Owl runs the course's C server (MRSsocket.c: one client per launch) can script a session.
//
// Script language, one command per line; '#' starts a comment; blank lines are skipped:
//   move Rx Ry Lx Ly Neck     five pulse widths [us], wire order; decimal digits only
//   centre                    the robot file's centre pose (also: center)
//   wait SECONDS              sleep (0 < SECONDS <= 3600; decimal, e.g. 0.5) (also: sleep)
//   quit                      end the session here (also: exit)
// Every command goes through the robot's LimitsGuard (a clamp is reported, never silent).
// ParseShellScript checks a whole script before anything moves; errors name source:line.
//
// Usage:
//   std::vector<ShellCommand> script = ParseShellScript(text, "session.owl");
//   OwlLink link(options);                       // one connection for the whole script
//   ShellResult r = RunShellScript(script, link, std::cout);
#include <iosfwd>
#include <optional>
#include <string>
#include <vector>

#include "robot/robot_interface.h"

namespace owlcal::robot {

struct ShellCommand {
  enum class Kind { kMove, kCentre, kWait, kQuit } kind = Kind::kMove;
  PwmVector pwm_us{};  // kMove
  double seconds = 0;  // kWait
  int line = 0;        // 1-based line in the source
  std::string text;    // the line as written (trimmed, without comment)
};

// Parses one line; nullopt for a blank or comment line. Throws std::invalid_argument
// "SOURCE:LINE: ..." naming what is wrong.
std::optional<ShellCommand> ParseShellLine(const std::string& line, int line_number, const std::string& source);
// Parses a whole script (all lines checked first). Throws as ParseShellLine.
std::vector<ShellCommand> ParseShellScript(const std::string& text, const std::string& source);

struct ShellResult {
  int num_moves = 0;    // servo packets sent (move + centre)
  int num_clamped = 0;  // of them, changed by the limits guard
  double waited_s = 0;
  bool quit = false;  // ended by a quit command
};

// Runs the commands on `robot` in order, printing one line per command to `out`: what was
// sent, any clamp, the reply (non-printable bytes shown as \n, \r, \xNN). A servo command that
// is not answered throws (robot.SendServos' error, naming the command's line).
ShellResult RunShellScript(const std::vector<ShellCommand>& script, RobotInterface& robot, std::ostream& out);

// A reply as printable text: "1545\n\r" -> 1545\n\r (escaped), at most 64 bytes shown.
std::string PrintableReply(const std::string& reply);

}  // namespace owlcal::robot
