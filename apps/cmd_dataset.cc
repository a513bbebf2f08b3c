// owlcal dataset check|repair|info DIR: inspect recorded datasets (protocols/dataset.h).
#include <iostream>
#include <map>
#include <memory>

#include "apps/command_registry.h"
#include "protocols/dataset.h"

namespace owlcal::apps {
namespace {

struct DatasetCmdOptions {
  std::string dir;
  bool no_crc = false;
  bool quiet = false;
};

void PrintCheck(const protocols::DatasetCheck& c, bool quiet) {
  for (const std::string& e : c.errors) std::cout << "error: " << e << "\n";
  if (!quiet)
    for (const std::string& w : c.warnings) std::cout << "warning: " << w << "\n";
  std::cout << (c.ok ? "ok" : "NOT ok") << ": " << c.num_frames << " frames, status '" << c.status << "'\n";
}

int RunCheck(const DatasetCmdOptions& o) {
  const protocols::DatasetCheck c = protocols::CheckDataset(o.dir, !o.no_crc);
  PrintCheck(c, o.quiet);
  return c.ok ? kExitOk : kExitFailed;
}

int RunRepair(const DatasetCmdOptions& o) {
  const protocols::DatasetCheck c = protocols::RepairDataset(o.dir);
  PrintCheck(c, o.quiet);
  std::cout << "repaired: partial lines and orphan frame files removed\n";
  return kExitOk;
}

int RunInfo(const DatasetCmdOptions& o) {
  const nlohmann::json m = protocols::ReadManifest(o.dir);
  const auto frames = protocols::ReadFramesCsv(o.dir);
  std::cout << "dataset " << o.dir << "\n  owlcal " << m.value("owlcal_version", "?") << ", created "
            << m.value("created_utc", "?") << ", status " << m.value("status", "?") << "\n";
  if (m.contains("robot")) std::cout << "  robot: " << m["robot"].value("description", "?") << "\n";
  if (m.contains("protocols"))
    for (const auto& p : m["protocols"])
      std::cout << "  protocol: " << p.value("name", "?") << " (" << p.value("file", "") << ")\n";
  std::map<std::string, int> per_step;
  for (const auto& f : frames) per_step[std::to_string(f.step_index) + " " + f.step_name]++;
  std::cout << "  " << frames.size() << " frames, " << protocols::ReadPlacementsCsv(o.dir).size() << " placements\n";
  for (const auto& [step, n] : per_step) std::cout << "    step " << step << ": " << n << " frames\n";
  return kExitOk;
}

const bool kDatasetRegistered = RegisterCommand(
    "dataset",
    "Inspect a recorded dataset: check (exit 1 if unusable), repair (drop a partial tail), info.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<DatasetCmdOptions>();
      cmd->require_subcommand(1);
      auto add = [&](const char* name, const char* help) {
        CLI::App* sub = cmd->add_subcommand(name, help);
        sub->add_option("dir", o->dir, "dataset folder")->required()->check(CLI::ExistingDirectory);
        sub->add_flag("--quiet", o->quiet, "errors only");
        if (std::string(name) == "check") sub->add_flag("--no-crc", o->no_crc, "skip the JPEG CRC check (sizes only)");
        return sub;
      };
      CLI::App* check =
          add("check", "check a dataset (a run killed at any moment passes, minus its last partial frame)");
      CLI::App* repair =
          add("repair", "make an interrupted dataset clean (truncate partial lines, drop orphan frames)");
      CLI::App* info = add("info", "summarise a dataset");
      return [o, check, repair, info] {
        if (check->parsed()) return RunCheck(*o);
        if (repair->parsed()) return RunRepair(*o);
        if (info->parsed()) return RunInfo(*o);
        return kExitUsage;
      };
    });

}  // namespace
}  // namespace owlcal::apps
