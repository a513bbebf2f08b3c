// DatasetWriter (protocols/dataset.h): creating and resuming a dataset folder, appending frames,
// placements, steps, events and measurement rows one whole record at a time, setting superseded
// steps apart on resume, and the manifest.
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <set>
#include <stdexcept>

#include "calib/csv.h"
#include "io/atomic_file.h"
#include "protocols/dataset.h"
#include "protocols/dataset_rows.h"

namespace owlcal::protocols {
namespace fs = std::filesystem;
namespace {

std::string UtcNow() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace

std::unique_ptr<DatasetWriter> DatasetWriter::Create(const std::string& dir, nlohmann::json manifest) {
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "frames", ec);
  if (ec) throw std::runtime_error(dir + ": cannot create dataset folder: " + ec.message());
  if (fs::exists(fs::path(dir) / "manifest.json"))
    throw std::runtime_error(dir + ": already holds a dataset (manifest.json); use --resume or another --out");
  std::unique_ptr<DatasetWriter> w(new DatasetWriter);
  w->dir_ = dir;
  manifest["format"] = kDatasetFormat;
  manifest["format_version"] = kDatasetFormatVersion;
  manifest["created_utc"] = UtcNow();
  manifest["status"] = "running";
  w->manifest_ = std::move(manifest);
  w->WriteManifest();
  w->Open("frames.csv", kFramesCsvHeader);
  w->Open("placements.csv", kPlacementsCsvHeader);
  w->Open("steps.csv", kStepsCsvHeader);
  return w;
}

std::unique_ptr<DatasetWriter> DatasetWriter::Resume(const std::string& dir) {
  RepairDataset(dir);
  std::unique_ptr<DatasetWriter> w(new DatasetWriter);
  w->dir_ = dir;
  w->manifest_ = ReadManifest(dir);
  w->next_frame_index_ = static_cast<int64_t>(ReadFramesCsv(dir).size());
  w->placements_ = ReadPlacementsCsv(dir);
  w->next_placement_index_ = static_cast<int>(w->placements_.size());
  w->steps_ = ReadStepsCsv(dir);
  w->manifest_["status"] = "running";
  w->manifest_["resumed_utc"].push_back(UtcNow());
  w->WriteManifest();
  return w;
}

int64_t DatasetWriter::SupersedeFrom(int first_step, int64_t stamp_ns) {
  for (auto& [name, f] : files_) std::fclose(f);  // every table is rewritten below
  files_.clear();
  const fs::path dir(dir_);
  // frames.csv: relabel, keep every line (frame_index stays contiguous, JPEGs stay).
  std::set<int64_t> superseded;
  const std::string frames_path = (dir / "frames.csv").string();
  const calib::CsvTable frames = ReadAppendedCsv(frames_path);
  internal::CheckHeader(frames, kFramesCsvHeader);
  std::string out = std::string(kFramesCsvHeader) + "\n";
  for (size_t i = 0; i < frames.NumRows(); ++i) {
    FrameRecord r = internal::ParseFrameRow(frames.Cells(i), frames.Where(i));
    if (r.step_index >= first_step) {
      superseded.insert(r.frame_index);
      r.step_name = "superseded:" + r.step_name;
      r.step_index = -1;
    }
    out += internal::FrameLine(r);
  }
  if (!superseded.empty()) io::WriteFileAtomic(frames_path, out);
  // Tables: move rows of the superseded steps (or frames) out.
  int64_t moved = 0;
  std::vector<fs::path> tables;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.is_regular_file() && e.path().extension() == ".csv") tables.push_back(e.path());
  std::sort(tables.begin(), tables.end());
  for (const fs::path& path : tables) {
    const std::string name = path.filename().string();
    if (name == "frames.csv" || name == "placements.csv" || name == "steps.csv") continue;
    const calib::CsvTable t = ReadAppendedCsv(path.string());
    if (t.Header().empty()) continue;
    const std::string& key_column = t.Header()[0];
    const bool by_step = key_column == "step_index";
    const bool by_frame = key_column == "frame_index";
    if (!by_step && !by_frame) continue;
    const std::string header_line = internal::CsvLine(t.Header());
    std::string keep = header_line, gone;
    int64_t num_gone = 0;
    for (size_t i = 0; i < t.NumRows(); ++i) {
      const int64_t key = t.Integer(i, key_column, INT64_MIN, INT64_MAX);
      const bool drop = by_step ? key >= first_step : superseded.count(key) > 0;
      (drop ? gone : keep) += internal::CsvLine(t.Cells(i));
      num_gone += drop;
    }
    if (gone.empty()) continue;
    fs::create_directories(dir / "superseded");
    const fs::path side = dir / "superseded" / name;
    const bool fresh = !fs::exists(side) || fs::file_size(side) == 0;
    const std::string previous = fresh ? header_line : internal::ReadWholeFile(side.string());
    io::WriteFileAtomic(side.string(), previous + gone);  // first, so a crash here loses nothing
    io::WriteFileAtomic(path.string(), keep);
    moved += num_gone;
  }
  if (superseded.empty() && moved == 0) return 0;  // stopped between steps: nothing to set apart
  Event(stamp_ns,
        "supersede",
        "resuming at step " + std::to_string(first_step) + ": " + std::to_string(superseded.size()) +
            " frames relabelled 'superseded:', " + std::to_string(moved) + " table rows moved to superseded/");
  return static_cast<int64_t>(superseded.size());
}

DatasetWriter::~DatasetWriter() {
  for (auto& [name, f] : files_) std::fclose(f);
}

void DatasetWriter::WriteManifest() {
  io::WriteFileAtomic((fs::path(dir_) / "manifest.json").string(), manifest_.dump(2) + "\n");
}

void DatasetWriter::Finish(const std::string& status, const std::string& message) {
  manifest_["status"] = status;
  manifest_["message"] = message;
  manifest_["finished_utc"] = UtcNow();
  manifest_["num_frames"] = next_frame_index_;
  WriteManifest();
}

FILE* DatasetWriter::Open(const std::string& name, const std::string& header) {
  auto it = files_.find(name);
  if (it != files_.end()) return it->second;
  const std::string path = (fs::path(dir_) / name).string();
  const bool fresh = !fs::exists(path) || fs::file_size(path) == 0;
  FILE* f = std::fopen(path.c_str(), "ab");
  if (!f) throw std::runtime_error(path + ": cannot open for appending: " + std::strerror(errno));
  files_[name] = f;
  if (fresh && !header.empty()) AppendLine(f, name, header + "\n");
  return f;
}

void DatasetWriter::AppendLine(FILE* f, const std::string& name, const std::string& line) {
  if (std::fwrite(line.data(), 1, line.size(), f) != line.size() || std::fflush(f) != 0)
    throw std::runtime_error((fs::path(dir_) / name).string() + ": write failed: " + std::strerror(errno));
}

int64_t DatasetWriter::AppendFrame(const std::vector<uint8_t>& jpeg, FrameRecord record) {
  record.frame_index = next_frame_index_;
  record.jpeg_bytes = static_cast<int64_t>(jpeg.size());
  record.jpeg_crc32 = Crc32(jpeg.data(), jpeg.size());
  const std::string path = FramePath(dir_, record.frame_index);
  io::WriteFileAtomic(path, std::string_view(reinterpret_cast<const char*>(jpeg.data()), jpeg.size()));
  AppendLine(Open("frames.csv", kFramesCsvHeader), "frames.csv", internal::FrameLine(record));
  return next_frame_index_++;
}

int DatasetWriter::AppendPlacement(PlacementRecord placement) {
  placement.placement_index = next_placement_index_;
  AppendLine(Open("placements.csv", kPlacementsCsvHeader), "placements.csv", internal::PlacementLine(placement));
  placements_.push_back(placement);
  return next_placement_index_++;
}

void DatasetWriter::AppendStep(const StepRecord& step) {
  AppendLine(Open("steps.csv", kStepsCsvHeader), "steps.csv", internal::StepLine(step));
  steps_.push_back(step);
}

void DatasetWriter::Event(int64_t stamp_ns, const std::string& kind, const std::string& message) {
  std::string m = message;
  for (char& c : m)
    if (c == '\n' || c == '\t') c = ' ';
  AppendLine(Open("events.log", ""), "events.log", std::to_string(stamp_ns) + "\t" + kind + "\t" + m + "\n");
}

void DatasetWriter::AppendRow(const std::string& name, const std::string& header, const std::vector<std::string>& row) {
  std::string line;
  for (size_t i = 0; i < row.size(); ++i) {
    if (i) line.push_back(',');
    line.append(calib::CsvCell(row[i]));
  }
  line.push_back('\n');
  AppendLine(Open(name, header), name, line);
}

}  // namespace owlcal::protocols
