// The dataset format's names and readers (protocols/dataset.h): the table headers, CRC-32, frame
// paths, the manifest and the typed readers of frames.csv, placements.csv and steps.csv. Writing:
// protocols/dataset_writer.cc; the rows: protocols/dataset_rows.cc; checking and repair:
// protocols/dataset_check.cc.
#include "protocols/dataset.h"

#include <array>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "calib/csv.h"
#include "io/json_strict.h"
#include "protocols/dataset_rows.h"

namespace owlcal::protocols {
namespace fs = std::filesystem;

const char* const kFramesCsvHeader =
    "frame_index,seq,stamp_ns,Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,approach_Rx,approach_Ry,approach_Lx,"
    "approach_Ly,approach_Neck,step_index,step_name,placement_index,jpeg_bytes,jpeg_crc32";
const char* const kPlacementsCsvHeader =
    "placement_index,step_index,target,distance_m,tx_m,ty_m,tz_m,qx,qy,qz,qw,source,answer,stamp_ns";
const char* const kStepsCsvHeader = "step_index,step_name,kind,status,start_ns,end_ns,num_frames";

namespace {

// Header check + every complete row parsed by `parse`; a partial tail is ignored.
template <typename R, typename Parse>
std::vector<R> ReadTable(const std::string& path, const char* header, Parse parse) {
  const calib::CsvTable t = ReadAppendedCsv(path);
  internal::CheckHeader(t, header);
  std::vector<R> out;
  for (size_t r = 0; r < t.NumRows(); ++r) out.push_back(parse(t.Cells(r), t.Where(r)));
  return out;
}

}  // namespace

uint32_t Crc32(const uint8_t* data, size_t size) {
  static const auto table = [] {
    std::array<uint32_t, 256> t{};
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  uint32_t c = 0xFFFFFFFFu;
  for (size_t i = 0; i < size; ++i) c = table[(c ^ data[i]) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

std::string FramePath(const std::string& dir, int64_t frame_index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06" PRId64 ".jpg", frame_index);
  return (fs::path(dir) / "frames" / name).string();
}

calib::CsvTable ReadAppendedCsv(const std::string& path) {
  calib::CsvOptions o;
  o.skip_blank_lines = false;  // a blank line in a table the runner wrote is damage, not layout
  o.allow_partial_tail = true;
  o.tail_needs_line_break = true;
  o.allow_empty = true;
  if (!fs::exists(path)) return calib::CsvTable::Parse("", path, o);
  return calib::CsvTable::Read(path, o);
}

nlohmann::json ReadManifest(const std::string& dir) {
  const std::string path = (fs::path(dir) / "manifest.json").string();
  if (!fs::exists(path)) throw std::runtime_error(path + ": missing (not a dataset folder)");
  // Strict: a key given twice is an error (io/json_strict.h), as is invalid JSON.
  const nlohmann::json j = io::ParseJsonStrict(internal::ReadWholeFile(path), path);
  if (!j.is_object() || j.value("format", "") != kDatasetFormat)
    throw std::runtime_error(path + ": field 'format' is not '" + std::string(kDatasetFormat) + "'");
  return j;
}

std::vector<FrameRecord> ReadFramesCsv(const std::string& dir) {
  return ReadTable<FrameRecord>((fs::path(dir) / "frames.csv").string(), kFramesCsvHeader, internal::ParseFrameRow);
}
std::vector<PlacementRecord> ReadPlacementsCsv(const std::string& dir) {
  return ReadTable<PlacementRecord>(
      (fs::path(dir) / "placements.csv").string(), kPlacementsCsvHeader, internal::ParsePlacementRow);
}
std::vector<StepRecord> ReadStepsCsv(const std::string& dir) {
  return ReadTable<StepRecord>((fs::path(dir) / "steps.csv").string(), kStepsCsvHeader, internal::ParseStepRow);
}

std::vector<uint8_t> ReadFrameJpeg(const std::string& dir, int64_t frame_index) {
  const std::string data = internal::ReadWholeFile(FramePath(dir, frame_index));
  return std::vector<uint8_t>(data.begin(), data.end());
}

}  // namespace owlcal::protocols
