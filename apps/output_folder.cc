#include "apps/output_folder.h"

#include <chrono>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <stdexcept>
#include <system_error>

#include <nlohmann/json.hpp>

#include "apps/command_registry.h"
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
                                                  "report",
                                                  "vergence_fit.md",
                                                  "vergence_rows.csv",
                                                  "toe_in_fit.md",
                                                  "toe_in_sets.csv",
                                                  "sets"};
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
    auto names_owlcal = [](const nlohmann::json& j) {
      return j.is_object() && j.contains("software") && j.at("software").is_object() &&
             j.at("software").value("name", "") == "owlcal";
    };
    return names_owlcal(r) || (r.contains("inputs") && names_owlcal(r.at("inputs")));
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

std::string StartRun(const std::string& out, const std::function<void(const std::string&)>& say) {
  const std::string run_id = NewRunId();
  const std::vector<std::string> removed = RemoveEarlierRun(out, run_id);
  if (!removed.empty()) {
    std::string list;
    for (const auto& f : removed) list += (list.empty() ? "" : ", ") + f;
    say("removed what an earlier run left in " + out + ": " + list);
  }
  return run_id;
}

void CheckInputOutsideRun(const std::string& out, const std::string& input, const std::string& what) {
  std::error_code ec;
  const fs::path o = fs::weakly_canonical(fs::absolute(out), ec);
  const fs::path in = fs::weakly_canonical(fs::absolute(input), ec);
  if (ec) return;  // a path that cannot be resolved is reported by the reader, naming it
  const fs::path rel = in.lexically_relative(o);
  if (rel.empty() || *rel.begin() == "..") return;
  if (rel == ".")
    throw UsageError(what + " " + input + " is the output folder " + out +
                     ": the run would remove what it reads before it starts; give another --out");
  const std::string top = rel.begin()->string();
  const bool itself = std::next(rel.begin()) == rel.end();
  for (const std::string& name : RunOutputNames())
    if (top == name)
      throw UsageError(
          what + " " + input +
          (itself ? " is one of the files" : " lies in " + (fs::path(out) / name).string() + ", one of the folders") +
          " a run into " + out + " removes before it starts; give another --out");
}

}  // namespace owlcal::apps
