// owlcal shell --robot HOST[:PORT] [SCRIPT]: several servo commands (move, centre, wait) over
// ONE connection, for a robot whose servo server takes one client per launch (the course's C
// server, MRSsocket.c; `owlcal sim --server c`).
//
// Consumes: a script file (robot/shell_script.h: move Rx Ry Lx Ly Neck / centre / wait S /
// quit, '#' comments), or standard input ("-" or no SCRIPT): from a terminal one line at a time
// (a bad line is reported and skipped), otherwise read whole and checked first. Produces: one
// line per command (sent, clamp, reply) and a summary. Exit 0, 1 if a command went unanswered,
// 2 for a bad script.
#include <unistd.h>

#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "apps/command_registry.h"
#include "robot/link_commands.h"
#include "robot/owl_link.h"
#include "robot/shell_script.h"
#include "robot/socket_util.h"

namespace owlcal::apps {
namespace {

struct ShellOptions {
  std::string robot;
  std::string robot_file;
  std::string script = "-";
  int timeout_ms = 2000;
};

std::unique_ptr<robot::OwlLink> Connect(const ShellOptions& o) {
  const robot::HostPort hp = robot::ParseHostPort(o.robot, robot::kDefaultServoPort);
  robot::OwlLinkOptions lo;
  lo.host = hp.host;
  lo.servo_port = hp.port;
  lo.robot = robot::RobotConfigOrDefault(o.robot_file);
  lo.connect_timeout = std::chrono::milliseconds(o.timeout_ms);
  lo.reply_timeout = std::chrono::milliseconds(o.timeout_ms);
  lo.log = [](const std::string& line) { std::cerr << "owlcal shell: " << line << "\n"; };
  return std::make_unique<robot::OwlLink>(lo);
}

void PrintSummary(const robot::ShellResult& r, const std::string& robot) {
  std::cout << "shell: " << r.num_moves << " servo commands (" << r.num_clamped << " clamped), waited " << r.waited_s
            << " s, over one connection to " << robot << "\n";
}

int RunShell(const ShellOptions& o) {
  const bool from_stdin = o.script == "-";
  if (from_stdin && ::isatty(STDIN_FILENO)) {
    // Interactive: one line at a time; a bad line is reported and skipped.
    std::unique_ptr<robot::OwlLink> link = Connect(o);
    std::cout << "owlcal shell on " << link->Describe() << ": move Rx Ry Lx Ly Neck | centre | wait SECONDS | quit\n> "
              << std::flush;
    robot::ShellResult total;
    int n = 0;
    for (std::string line; std::getline(std::cin, line);) {
      try {
        if (auto c = robot::ParseShellLine(line, ++n, "stdin")) {
          const robot::ShellResult r = robot::RunShellScript({*c}, *link, std::cout);
          total.num_moves += r.num_moves;
          total.num_clamped += r.num_clamped;
          total.waited_s += r.waited_s;
          if (r.quit) break;
        }
      } catch (const std::invalid_argument& e) {
        std::cout << e.what() << "\n";
      }
      std::cout << "> " << std::flush;
    }
    link->Close();
    PrintSummary(total, o.robot);
    return kExitOk;
  }
  std::string text;
  if (from_stdin) {
    std::ostringstream s;
    s << std::cin.rdbuf();
    text = s.str();
  } else {
    std::ifstream in(o.script);
    if (!in) throw UsageError(o.script + ": cannot read the script");
    std::ostringstream s;
    s << in.rdbuf();
    text = s.str();
  }
  std::vector<robot::ShellCommand> script;
  try {
    script = robot::ParseShellScript(text, from_stdin ? "stdin" : o.script);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  std::unique_ptr<robot::OwlLink> link = Connect(o);
  const robot::ShellResult r = robot::RunShellScript(script, *link, std::cout);
  link->Close();
  PrintSummary(r, o.robot);
  return kExitOk;
}

const bool kShellRegistered = RegisterCommand(
    "shell",
    "Send several servo commands over ONE connection: a script (or standard input) of\n"
    "  move Rx Ry Lx Ly Neck | centre | wait SECONDS | quit   ('#' comments)\n"
    "each clamped to the robot file's limits. For a one-client servo server such as the course's C\n"
    "server (MRSsocket.c), which exits when its client leaves: one `owlcal shell` session can move,\n"
    "wait and centre where separate `owlcal move` / `owlcal centre` runs would find the server gone.\n"
    "A script file is checked whole before anything moves.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<ShellOptions>();
      cmd->add_option("--robot", o->robot, "robot servo server HOST[:PORT] (port 12345 if omitted; no default host)")
          ->required();
      cmd->add_option(
             "--robot-file", o->robot_file, "robot file (YAML) with the limits and centres; default: the guide's")
          ->check(CLI::ExistingFile);
      cmd->add_option("--timeout-ms", o->timeout_ms, "connect and reply timeout [ms]")->check(CLI::Range(1, 60000));
      cmd->add_option("script", o->script, "script file, or - for standard input (the default)");
      return [o] { return RunShell(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
