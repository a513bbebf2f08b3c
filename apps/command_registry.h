#pragma once
// Subcommands of the `owlcal` program register themselves here, one file each
// (apps/cmd_<name>.cc), so adding a command touches no shared file (the registration variable is
// named after the command: the files are compiled together in a unity build):
//
//   namespace {
//   const bool kMoveRegistered = owlcal::apps::RegisterCommand(
//       "move", "Send one servo command (pulse widths in us) and print the reply",
//       [](CLI::App* cmd) {
//         auto opts = std::make_shared<MoveOptions>();
//         cmd->add_option("--robot", opts->robot, "HOST[:PORT]")->required();
//         return [opts] { return RunMove(*opts); };
//       });
//   }
//
// A command's run function returns the exit code: 0 ok, 1 failed (the message already
// printed). Exceptions escaping it print "owlcal <cmd>: <what>" and exit 1; bad usage
// exits 2.
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace owlcal::apps {

inline constexpr int kExitOk = 0;
inline constexpr int kExitFailed = 1;
inline constexpr int kExitUsage = 2;

using RunFunction = std::function<int()>;
using SetupFunction = std::function<RunFunction(CLI::App*)>;

struct CommandEntry {
  std::string name;
  std::string help;
  SetupFunction setup;
};

std::vector<CommandEntry>& CommandRegistry();

inline bool RegisterCommand(std::string name, std::string help, SetupFunction setup) {
  CommandRegistry().push_back({std::move(name), std::move(help), std::move(setup)});
  return true;
}

// Thrown by a command for bad input discovered after parsing (exit code 2).
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

}  // namespace owlcal::apps
