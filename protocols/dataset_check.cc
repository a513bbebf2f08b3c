// Checking and repairing a dataset folder (CheckDataset, RepairDataset, protocols/dataset.h): the
// manifest, frames.csv against the frame files (sizes, CRCs, orphans), the other tables, and the
// truncation of a crash's partial tails.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/csv.h"
#include "io/atomic_file.h"
#include "protocols/dataset.h"
#include "protocols/dataset_rows.h"

namespace owlcal::protocols {
namespace fs = std::filesystem;

namespace {

// The manifest's num_frames (written when the run finished) against the `lines` complete lines
// of frames.csv: within kMaxDatasetFrames, and equal to them, allowing for the one cut last line
// a check drops; a run still marked running may have recorded more frames since.
void CheckManifestFrameCount(
    const nlohmann::json& manifest, const std::string& dir, int64_t lines, bool dropped_tail, DatasetCheck* c) {
  if (!manifest.contains("num_frames")) return;
  const std::string where = (fs::path(dir) / "manifest.json").string() + " field num_frames";
  const nlohmann::json& n = manifest.at("num_frames");
  if (!n.is_number_integer() || n.get<int64_t>() < 0 || n.get<int64_t>() > kMaxDatasetFrames) {
    c->errors.push_back(where + " = " + n.dump() + " is not a frame count (an integer within 0.." +
                        std::to_string(kMaxDatasetFrames) + ")");
    return;
  }
  const int64_t claimed = n.get<int64_t>();
  const bool running = c->status == "running";
  if (claimed > lines + (dropped_tail ? 1 : 0) || (!running && lines > claimed)) {
    c->errors.push_back(where + " = " + std::to_string(claimed) + " but frames.csv has " + std::to_string(lines) +
                        " complete line(s)" + (running ? "" : " (status '" + c->status + "')"));
  }
}

}  // namespace

DatasetCheck CheckDataset(const std::string& dir, bool verify_crc) {
  DatasetCheck c;
  auto error = [&](const std::string& e) { c.errors.push_back(e); };
  nlohmann::json manifest;
  try {
    manifest = ReadManifest(dir);
    c.status = manifest.value("status", "");
    if (c.status == "running") c.warnings.push_back("manifest.json: status 'running': the run was interrupted");
  } catch (const std::exception& e) {
    error(e.what());
    return c;
  }
  // frames.csv
  const std::string frames_csv = (fs::path(dir) / "frames.csv").string();
  if (!fs::exists(frames_csv)) error(frames_csv + ": missing");
  calib::CsvTable frames = calib::CsvTable::Parse("", frames_csv, {.allow_empty = true});
  try {
    frames = ReadAppendedCsv(frames_csv);
    internal::CheckHeader(frames, kFramesCsvHeader);
  } catch (const std::exception& e) {
    error(e.what());
  }
  if (frames.DroppedPartialTail())
    c.warnings.push_back(frames_csv + ": partial last line dropped (the run was cut while writing it)");
  int64_t expected = 0;
  for (size_t i = 0; i < frames.NumRows() && c.errors.empty(); ++i) {
    const std::string where = frames.Where(i);
    FrameRecord r;
    try {
      r = internal::ParseFrameRow(frames.Cells(i), where);
    } catch (const std::exception& e) {
      error(e.what());
      break;
    }
    if (r.frame_index != expected) {
      error(where + " field frame_index: " + std::to_string(r.frame_index) + ", expected " + std::to_string(expected));
      break;
    }
    const std::string path = FramePath(dir, r.frame_index);
    std::error_code ec;
    const auto size = fs::file_size(path, ec);
    if (ec) {
      error(where + ": frame file " + path + " is missing");
      break;
    }
    if (static_cast<int64_t>(size) != r.jpeg_bytes) {
      error(where + " field jpeg_bytes: " + std::to_string(r.jpeg_bytes) + " but " + path + " has " +
            std::to_string(size) + " bytes");
      break;
    }
    if (verify_crc) {
      const std::vector<uint8_t> jpeg = ReadFrameJpeg(dir, r.frame_index);
      if (Crc32(jpeg.data(), jpeg.size()) != r.jpeg_crc32) {
        error(where + " field jpeg_crc32: " + path + " does not match its CRC");
        break;
      }
    }
    ++expected;
  }
  c.num_frames = expected;
  CheckManifestFrameCount(manifest, dir, expected, frames.DroppedPartialTail(), &c);
  // Orphans: frame files beyond the last line (the frame being recorded when the run stopped).
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "frames", ec)) {
    const std::string name = e.path().filename().string();
    if (io::IsAtomicTemporary(name)) {
      c.warnings.push_back(e.path().string() + ": unfinished frame file dropped");
      continue;
    }
    int64_t index = -1;
    try {
      index = std::stoll(name);
    } catch (const std::exception&) {
      c.warnings.push_back(e.path().string() + ": not a frame file");
      continue;
    }
    if (index >= expected) c.warnings.push_back(e.path().string() + ": frame without a frames.csv line dropped");
  }
  // Other tables: parse; tolerate a partial tail.
  auto check_table = [&](const std::string& name, const char* header, auto parse) {
    const std::string path = (fs::path(dir) / name).string();
    try {
      const calib::CsvTable t = ReadAppendedCsv(path);
      if (t.DroppedPartialTail()) c.warnings.push_back(path + ": partial last line dropped");
      internal::CheckHeader(t, header);
      for (size_t i = 0; i < t.NumRows(); ++i) parse(t.Cells(i), t.Where(i));
    } catch (const std::exception& e) {
      error(e.what());
    }
  };
  check_table("placements.csv", kPlacementsCsvHeader, internal::ParsePlacementRow);
  check_table("steps.csv", kStepsCsvHeader, internal::ParseStepRow);
  c.ok = c.errors.empty();
  return c;
}

DatasetCheck RepairDataset(const std::string& dir) {
  DatasetCheck c = CheckDataset(dir, true);
  if (!c.ok) {
    std::string msg = dir + ": dataset cannot be repaired:";
    for (const std::string& e : c.errors) msg += "\n  " + e;
    throw std::runtime_error(msg);
  }
  // Truncate the partial tails of every CSV (a record may span lines inside quotes) and text log.
  for (const auto& e : fs::directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const std::string ext = e.path().extension().string();
    if (ext == ".csv") {
      const calib::CsvTable t = ReadAppendedCsv(e.path().string());
      if (t.DroppedPartialTail()) fs::resize_file(e.path(), t.CompleteBytes());
    } else if (ext == ".log") {
      const std::string text = internal::ReadWholeFile(e.path().string());
      const size_t nl = text.rfind('\n');
      const size_t complete = nl == std::string::npos ? 0 : nl + 1;
      if (complete < text.size()) fs::resize_file(e.path(), complete);
    }
  }
  for (const auto& e : fs::directory_iterator(fs::path(dir) / "frames")) {
    const std::string name = e.path().filename().string();
    bool remove = io::IsAtomicTemporary(name);
    if (!remove) {
      try {
        remove = std::stoll(name) >= c.num_frames;
      } catch (const std::exception&) {
      }
    }
    if (remove) fs::remove(e.path());
  }
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("manifest.json.tmp", 0) == 0 && io::IsAtomicTemporary(name)) fs::remove(e.path());
  }
  return c;
}

}  // namespace owlcal::protocols
