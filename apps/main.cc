// owlcal: calibration and measurement suite for the Plymouth Owl stereo robot head.
#include <algorithm>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "apps/command_registry.h"
#include "owlcal_version.h"

namespace owlcal::apps {
std::vector<CommandEntry>& CommandRegistry() {
  static std::vector<CommandEntry> registry;
  return registry;
}

namespace {

// The heading each command is listed under by `owlcal --help`, and its one-line summary there
// (`owlcal CMD --help` prints the full description the command registered). Groups are listed
// in this order; a command missing here is listed under "Other" with its description's first line.
struct CommandGroup {
  const char* heading;
  std::vector<std::pair<const char*, const char*>> commands;  // name, one-line summary
};

const std::vector<CommandGroup>& CommandGroups() {
  static const std::vector<CommandGroup> groups = {
      {"Robot",
       {{"centre", "send the robot file's centre pose"},
        {"move", "send one servo command (Rx Ry Lx Ly Neck, us), clamped to the limits"},
        {"grab", "save one stereo frame of the stream as left.png, right.png, frame.jpg"},
        {"jog", "find each servo's range by hand; writes a robot file and the Pi's clamp table"},
        {"shell", "send several servo commands over one connection (script or stdin)"},
        {"run", "run experiment protocols and record a dataset"}}},
      {"Calibration",
       {{"calibrate", "the main job: record the standard suite, fit, evaluate, write the report"},
        {"fit-datasets", "re-fit a calibration folder's recorded datasets without a robot"},
        {"calibrate-images", "stereo calibration from a folder of image pairs, with a verdict"},
        {"check-calibration", "check a calibration on new images of the board (still valid?)"},
        {"pose-calibration", "the stereo calibration at any servo command, from the head fit"}}},
      {"Experiments",
       {{"vor", "the vestibulo-ocular reflex: gain, phase and image slip"},
        {"catch-up", "catch-up saccades on a target moving at 10-30 deg/s"},
        {"main-sequence", "the saccade main sequence: peak velocity and duration against amplitude"},
        {"track", "salience targets and Lucas-Kanade tracking"},
        {"sharpness", "lens sharpness against distance: focus and depth of field"}}},
      {"Offline (files in, files out; no robot)",
       {{"detect", "detect a chessboard or AprilGrid in images or a dataset; write observations"},
        {"detect-tags", "detect free-standing AprilTags in images; one CSV row per tag"},
        {"fit", "fit intrinsics (and stereo R, T) from an observation CSV"},
        {"fit-head", "fit servo maps, camera mounts, IPD and the neck map from servo sweeps"},
        {"fit-toe-in", "eye-pan servo maps from stereo calibrations at known pulse widths"},
        {"fit-vergence", "pan maps and range error from a vergence log CSV"},
        {"range-images", "range a target in stereo pairs with a calibration"},
        {"depth", "dense disparity and depth (SGBM) with a calibration"},
        {"compare-sessions", "compare calibrations of one robot from different sessions"},
        {"report", "redraw a calibration folder's figures, tables, exports and report"}}},
      {"Tools",
       {{"sim", "serve the virtual Owl in real time on loopback (for the course's programs)"},
        {"dataset", "check, repair or summarise a recorded dataset"},
        {"target", "write a printable calibration target at true scale (PDF or SVG)"}}},
  };
  return groups;
}

const char* const kOtherGroup = "Other";

// Lists a subcommand on one line: its summary from CommandGroups(), or its description's first line.
class OneLineFormatter : public CLI::Formatter {
 public:
  static constexpr size_t kNameWidth = 21;  // the longest name (check-calibration) and its indent, in columns

  explicit OneLineFormatter(std::map<std::string, std::string> summaries) : summaries_(std::move(summaries)) {}

  std::string make_subcommand(const CLI::App* sub) const override {
    const auto it = summaries_.find(sub->get_name());
    std::string line = it != summaries_.end() ? it->second : sub->get_description();
    line = line.substr(0, line.find('\n'));
    std::stringstream out;
    CLI::detail::format_help(out, sub->get_display_name(true), line, kNameWidth);
    return out.str();
  }

 private:
  std::map<std::string, std::string> summaries_;
};

}  // namespace
}  // namespace owlcal::apps

int main(int argc, char** argv) {
  using namespace owlcal::apps;
  CLI::App app{"owlcal " OWLCAL_VERSION
               " - calibration and measurement suite for the Plymouth Owl stereo robot head.\n"
               "With no --robot, commands that need a robot use the in-process virtual Owl;\n"
               "a real robot's address (e.g. 10.0.0.10) must always be given explicitly.\n"
               "`owlcal COMMAND --help` describes a command in full.",
               "owlcal"};
  app.set_version_flag("--version", "owlcal " OWLCAL_VERSION);
  app.require_subcommand(1);
  // Subcommands are added group by group (CLI11 lists groups in the order first seen).
  std::map<std::string, std::pair<size_t, std::string>> rank;  // name -> (order, group heading)
  std::map<std::string, std::string> summaries;
  for (const CommandGroup& g : CommandGroups()) {
    for (const auto& [name, summary] : g.commands) {
      rank.emplace(name, std::make_pair(rank.size(), g.heading));
      summaries.emplace(name, summary);
    }
  }
  auto order = [&](const CommandEntry& c) {
    const auto it = rank.find(c.name);
    return it != rank.end() ? it->second.first : rank.size();
  };
  std::vector<CommandEntry> commands = CommandRegistry();
  std::sort(commands.begin(), commands.end(), [&](const CommandEntry& a, const CommandEntry& b) {
    return std::make_pair(order(a), a.name) < std::make_pair(order(b), b.name);
  });
  app.formatter(std::make_shared<OneLineFormatter>(summaries));
  std::map<CLI::App*, RunFunction> runs;
  for (const CommandEntry& c : commands) {
    CLI::App* sub = app.add_subcommand(c.name, c.help);
    runs[sub] = c.setup(sub);
    const auto it = rank.find(c.name);  // after setup: a command's own subcommands keep CLI11's group
    sub->group(it != rank.end() ? it->second.second : kOtherGroup);
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
