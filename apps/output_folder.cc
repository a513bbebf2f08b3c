#include "apps/output_folder.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <random>
#include <stdexcept>
#include <system_error>

#include "io/atomic_file.h"

namespace owlcal::apps {

namespace fs = std::filesystem;

std::string NewRunId() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char when[32];
  std::strftime(when, sizeof(when), "%Y%m%dT%H%M%SZ", &utc);
  // Two runs started within one second still differ.
  std::random_device rd;
  char id[48];
  std::snprintf(id, sizeof(id), "%s-%08x", when, static_cast<unsigned>(rd()));
  return id;
}

const std::vector<std::string>& RunOutputNames() {
  static const std::vector<std::string> kNames = {"results.json",
                                                  "evaluation.json",
                                                  "calibration.yaml",
                                                  "intrinsics.xml",
                                                  "extrinsics.xml",
                                                  "robot_corrected.yaml",
                                                  "calibration.md",
                                                  "observations.csv",
                                                  "exports",
                                                  "figures",
                                                  "tables",
                                                  "report"};
  return kNames;
}

std::vector<std::string> RemoveEarlierRun(const std::string& out) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw std::runtime_error(out + ": cannot create the output folder: " + ec.message());
  std::vector<std::string> removed;
  auto remove = [&](const fs::path& p) {
    fs::remove_all(p, ec);
    if (ec)
      throw std::runtime_error(p.string() + ": cannot remove what an earlier run left: " + ec.message() +
                               " (the new run would mix with it)");
  };
  for (const std::string& name : RunOutputNames()) {
    const fs::path p = fs::path(out) / name;
    if (!fs::exists(fs::symlink_status(p))) continue;
    remove(p);
    removed.push_back(name);
  }
  // A killed atomic write's temporary of one of those files ("results.json.tmp-123").
  std::vector<fs::path> temporaries;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string n = e.path().filename().string();
    if (!e.is_regular_file() || !io::IsAtomicTemporary(n)) continue;
    for (const std::string& name : RunOutputNames())
      if (n.rfind(name + ".tmp", 0) == 0) temporaries.push_back(e.path());
  }
  for (const fs::path& p : temporaries) remove(p);
  return removed;
}

}  // namespace owlcal::apps
