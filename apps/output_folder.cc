#include "apps/output_folder.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <system_error>

#include <nlohmann/json.hpp>

#include "io/atomic_file.h"
#include "io/json_strict.h"

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

bool IsOwlcalOutputFolder(const std::string& out) {
  const fs::path dir(out);
  std::error_code ec;
  if (fs::is_regular_file(dir / kRunMarkerName, ec) || fs::is_regular_file(dir / "exports" / "owlcal_run.json", ec))
    return true;
  // An OpenCV calibration file owlcal wrote names its run (fitting/calibration_folder.h).
  for (const char* name : {"calibration.yaml", "intrinsics.xml", "extrinsics.xml"}) {
    std::ifstream f(dir / name);
    std::string head(4096, '\0');
    f.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<size_t>(f.gcount()));
    if (head.find("owlcal_run_id") != std::string::npos) return true;
  }
  if (!fs::is_regular_file(dir / "results.json", ec)) return false;
  try {
    const nlohmann::json r = io::ReadJsonFileStrict((dir / "results.json").string());
    if (!r.is_object()) return false;
    if (r.contains("run_id")) return true;
    const nlohmann::json* inputs = r.contains("inputs") ? &r.at("inputs") : nullptr;
    return inputs && inputs->is_object() && inputs->contains("software") && inputs->at("software").is_object() &&
           inputs->at("software").value("name", "") == "owlcal";
  } catch (const std::exception&) {
    return false;  // not JSON, or not owlcal's: a file of the user's
  }
}

std::vector<std::string> RemoveEarlierRun(const std::string& out, const std::string& run_id) {
  std::error_code ec;
  fs::create_directories(out, ec);
  if (ec) throw std::runtime_error(out + ": cannot create the output folder: " + ec.message());
  std::string present;
  for (const std::string& name : RunOutputNames())
    if (fs::exists(fs::symlink_status(fs::path(out) / name))) present += (present.empty() ? "" : ", ") + name;
  if (!present.empty() && !IsOwlcalOutputFolder(out))
    throw std::runtime_error(out + ": holds " + present + " but nothing that says owlcal wrote them (no " +
                             kRunMarkerName +
                             ", exports/owlcal_run.json, owlcal_run_id or owlcal results.json): nothing removed; give "
                             "another --out, or remove them yourself");
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
  io::WriteFileAtomic((fs::path(out) / kRunMarkerName).string(), run_id + "\n");
  return removed;
}

}  // namespace owlcal::apps
