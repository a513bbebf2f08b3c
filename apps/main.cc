// owlcal: calibration and measurement suite for the Plymouth Owl stereo robot head.
#include <algorithm>
#include <iostream>
#include <map>

#include "apps/command_registry.h"
#include "owlcal_version.h"

namespace owlcal::apps {
std::vector<CommandEntry>& CommandRegistry() {
  static std::vector<CommandEntry> registry;
  return registry;
}
}  // namespace owlcal::apps

int main(int argc, char** argv) {
  using namespace owlcal::apps;
  CLI::App app{
      "owlcal " OWLCAL_VERSION
      " - calibration and measurement suite for the Plymouth Owl stereo robot head.\n"
      "With no --robot, commands that need a robot use the in-process virtual Owl;\n"
      "a real robot's address (e.g. 10.0.0.10) must always be given explicitly.",
      "owlcal"};
  app.set_version_flag("--version", "owlcal " OWLCAL_VERSION);
  app.require_subcommand(1);
  std::vector<CommandEntry> commands = CommandRegistry();
  std::sort(commands.begin(), commands.end(), [](auto& a, auto& b) { return a.name < b.name; });
  std::map<CLI::App*, RunFunction> runs;
  for (const CommandEntry& c : commands) {
    CLI::App* sub = app.add_subcommand(c.name, c.help);
    runs[sub] = c.setup(sub);
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }
  for (auto& [sub, run] : runs) {
    if (!sub->parsed()) continue;
    try {
      return run();
    } catch (const UsageError& e) {
      std::cerr << "owlcal " << sub->get_name() << ": " << e.what() << "\n";
      return kExitUsage;
    } catch (const std::exception& e) {
      std::cerr << "owlcal " << sub->get_name() << ": " << e.what() << "\n";
      return kExitFailed;
    }
  }
  return kExitUsage;
}
