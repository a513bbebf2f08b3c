// owlcal compare-sessions A/results.json B/results.json ... --out DIR: calibrations of one
// robot from different sessions side by side, differences in sigma units.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "evaluation/session_compare.h"
#include "fitting/calibration_folder.h"
#include "reports/session_tables.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct CompareOptions {
  std::vector<std::string> results, names, params;
  std::string out;
  double z = 3;
};

int RunCompare(const CompareOptions& a) {
  if (a.results.size() < 2) throw UsageError("need at least two results.json files");
  if (!a.names.empty() && a.names.size() != a.results.size())
    throw UsageError("--names has " + std::to_string(a.names.size()) + " entries for " +
                     std::to_string(a.results.size()) + " results");
  std::vector<evaluation::NamedResult> s;
  for (size_t i = 0; i < a.results.size(); ++i) {
    fs::path p(a.results[i]);
    if (fs::is_directory(p)) p /= "results.json";
    const std::string name = a.names.empty() ? p.parent_path().filename().string() : a.names[i];
    fitting::CheckOneRunOfPath(p.string());  // a calibration folder's results.json: of one run
    s.push_back({name.empty() ? "session" + std::to_string(i + 1) : name, fitting::ReadResultJson(p.string())});
  }
  const auto c = evaluation::CompareSessions(s, a.params, a.z);
  const std::string md = "# Session comparison\n\n" + reports::SessionComparisonMarkdown(c);
  if (!a.out.empty()) {
    fs::create_directories(a.out);
    reports::WriteTextFile((fs::path(a.out) / "sessions.md").string(), md);
    reports::WriteTextFile((fs::path(a.out) / "sessions.csv").string(), reports::SessionComparisonCsv(c));
  }
  std::cout << md;
  return kExitOk;
}

const bool kCompareSessionsRegistered = RegisterCommand(
    "compare-sessions",
    "Compare calibrations of one robot from different sessions (results.json files or their folders):\n"
    "parameters side by side with sigma, each pair's differences in sigma units, and which changed.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CompareOptions>();
      cmd->add_option("results", o->results, "results.json files or folders holding one")->required();
      cmd->add_option("--names", o->names, "session names (default: folder names)");
      cmd->add_option("--params", o->params, "parameter names (default: every left.*, right.*, stereo.*)");
      cmd->add_option("--z", o->z, "|difference| / sigma above which a parameter counts as changed")
          ->capture_default_str();
      cmd->add_option("--out", o->out, "write sessions.md and sessions.csv here");
      return [o] { return RunCompare(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
