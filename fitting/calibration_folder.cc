#include "fitting/calibration_folder.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "fitting/opencv_calib_file.h"
#include "io/atomic_file.h"
#include "io/json_strict.h"

namespace owlcal::fitting {
namespace {

namespace fs = std::filesystem;

// The `run_id` string of a JSON file ("" when it has none).
std::string JsonRunId(const nlohmann::json& j, const std::string& path) {
  if (!j.is_object() || !j.contains("run_id")) return "";
  if (!j.at("run_id").is_string()) throw std::runtime_error(path + ": field 'run_id' is not a string");
  return j.at("run_id").get<std::string>();
}

}  // namespace

bool IsRunFileName(const std::string& file_name) {
  return std::any_of(std::begin(kRunIdFiles), std::end(kRunIdFiles), [&](const char* f) {
    return std::string(f).find('/') == std::string::npos && file_name == f;
  });
}

std::vector<FileRunId> RunIdsOfFolder(const std::string& dir) {
  const fs::path root(dir);
  std::vector<FileRunId> out;
  std::set<std::string> listed;  // export files exports/owlcal_run.json covers
  std::string exports_id;
  for (const char* name : kRunIdFiles) {
    const fs::path p = root / name;
    if (!fs::is_regular_file(p)) continue;
    const std::string file = name;
    std::string id;
    if (p.extension() == ".json") {
      const nlohmann::json j = io::ReadJsonFileStrict(p.string());
      id = JsonRunId(j, p.string());
      if (file == kExportsRunFile) {
        exports_id = id;
        if (j.contains("files")) {
          if (!j.at("files").is_array()) throw std::runtime_error(p.string() + ": field 'files' is not a list");
          for (const auto& f : j.at("files")) {
            if (!f.is_string()) throw std::runtime_error(p.string() + ": field 'files' holds a non-string");
            listed.insert(f.get<std::string>());
          }
        }
      }
    } else {
      id = ReadOpenCvCalibration(p.string()).run_id;
    }
    out.push_back({file, id});
  }
  // Every other export: of the manifest's run when it lists the file, of no known run otherwise
  // (an earlier run's leftover, or a file owlcal did not write).
  const fs::path ex = root / "exports";
  if (fs::is_directory(ex)) {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(ex)) {
      const std::string n = e.path().filename().string();
      if (!e.is_regular_file() || n == fs::path(kExportsRunFile).filename().string() || io::IsAtomicTemporary(n))
        continue;
      names.push_back(n);
    }
    std::sort(names.begin(), names.end());
    for (const auto& n : names) out.push_back({"exports/" + n, listed.count(n) ? exports_id : ""});
  }
  return out;
}

std::string MixedRunsError(const std::string& dir) {
  const std::vector<FileRunId> ids = RunIdsOfFolder(dir);
  std::set<std::string> distinct;
  for (const auto& f : ids) distinct.insert(f.run_id);
  if (distinct.size() <= 1) return "";
  // Group the files by run so a long exports/ list stays readable.
  std::map<std::string, std::vector<std::string>> by_id;
  for (const auto& f : ids) by_id[f.run_id].push_back(f.file);
  std::string s = dir + " holds files of different runs:";
  for (const auto& [id, files] : by_id) {
    s += id.empty() ? " no run id: " : " run ";
    if (!id.empty()) {
      s += id;
      s += ": ";
    }
    for (size_t i = 0; i < files.size(); ++i) {
      if (i) s += ", ";
      s += files[i];
    }
    s += ";";
  }
  s.back() = '.';
  return s +
         " A run that failed or ended unusable may have left an earlier run's files: calibrate again into this "
         "folder or a fresh one";
}

void CheckOneRun(const std::string& dir) {
  if (const std::string why = MixedRunsError(dir); !why.empty()) throw std::runtime_error(why);
}

void CheckOneRunOfPath(const std::string& path) {
  const fs::path p(path);
  if (fs::is_directory(p)) {
    CheckOneRun(path);
  } else if (IsRunFileName(p.filename().string())) {
    CheckOneRun(p.has_parent_path() ? p.parent_path().string() : std::string("."));
  }
}

}  // namespace owlcal::fitting
