#include "protocols/dataset.h"

#include "calib/csv.h"
#include "io/atomic_file.h"
#include "io/json_strict.h"
#include "io/strict_number.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <charconv>
#include <chrono>
#include <cinttypes>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace owlcal::protocols {
namespace fs = std::filesystem;

const char* const kFramesCsvHeader =
    "frame_index,seq,stamp_ns,Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,approach_Rx,approach_Ry,approach_Lx,"
    "approach_Ly,approach_Neck,step_index,step_name,placement_index,jpeg_bytes,jpeg_crc32";
const char* const kPlacementsCsvHeader =
    "placement_index,step_index,target,distance_m,tx_m,ty_m,tz_m,qx,qy,qz,qw,source,answer,stamp_ns";
const char* const kStepsCsvHeader = "step_index,step_name,kind,status,start_ns,end_ns,num_frames";

namespace {

constexpr int kFramesCsvFields = 18;
constexpr int kPlacementsCsvFields = 14;
constexpr int kStepsCsvFields = 7;

std::string UtcNow() {
  const std::time_t t = std::time(nullptr);
  char buf[32];
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// An integer within [min, max] (default: any int64).
int64_t ParseInt(const std::string& s, const std::string& where, int64_t min = INT64_MIN, int64_t max = INT64_MAX) {
  int64_t v = 0;
  const std::string why = io::CheckInteger(s, min, max, &v);
  if (!why.empty()) throw std::runtime_error(where + " " + why);
  return v;
}

// A finite number within [min, max].
double ParseDouble(const std::string& s, const std::string& where, double min = -1e6, double max = 1e6) {
  double v = 0;
  const std::string why = io::CheckNumber(s, min, max, &v);
  if (!why.empty()) throw std::runtime_error(where + " " + why);
  return v;
}

std::string Fmt(double v) {
  char buf[40];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

FrameRecord ParseFrameRow(const std::vector<std::string>& f, const std::string& where) {
  if (static_cast<int>(f.size()) != kFramesCsvFields)
    throw std::runtime_error(where + ": " + std::to_string(f.size()) + " fields, expected " +
                             std::to_string(kFramesCsvFields));
  static const char* names[kFramesCsvFields] = {"frame_index",
                                                "seq",
                                                "stamp_ns",
                                                "Rx_us",
                                                "Ry_us",
                                                "Lx_us",
                                                "Ly_us",
                                                "Neck_us",
                                                "approach_Rx",
                                                "approach_Ry",
                                                "approach_Lx",
                                                "approach_Ly",
                                                "approach_Neck",
                                                "step_index",
                                                "step_name",
                                                "placement_index",
                                                "jpeg_bytes",
                                                "jpeg_crc32"};
  auto w = [&](int i) { return where + " field " + names[i]; };
  FrameRecord r;
  r.frame_index = ParseInt(f[0], w(0), 0);
  r.seq = ParseInt(f[1], w(1));
  r.stamp_ns = ParseInt(f[2], w(2));
  for (int i = 0; i < models::kNumServos; ++i) r.pwm_us[i] = static_cast<int>(ParseInt(f[3 + i], w(3 + i), 0, 9999));
  for (int i = 0; i < models::kNumServos; ++i) r.approach[i] = static_cast<int8_t>(ParseInt(f[8 + i], w(8 + i), -1, 1));
  r.step_index = static_cast<int>(ParseInt(f[13], w(13), -1, INT32_MAX));
  r.step_name = f[14];
  r.placement_index = static_cast<int>(ParseInt(f[15], w(15), -1, INT32_MAX));
  r.jpeg_bytes = ParseInt(f[16], w(16), 0);
  const std::string& crc = f[17];
  const auto end = crc.data() + crc.size();
  const auto parsed = std::from_chars(crc.data(), end, r.jpeg_crc32, 16);
  if (crc.empty() || crc.size() > 8 || parsed.ec != std::errc() || parsed.ptr != end)
    throw std::runtime_error(w(17) + " = '" + io::Printable(crc) + "' is not a hex CRC-32");
  return r;
}

std::string FrameLine(const FrameRecord& r) {
  std::ostringstream s;
  s << r.frame_index << ',' << r.seq << ',' << r.stamp_ns;
  for (int v : r.pwm_us) s << ',' << v;
  for (int8_t a : r.approach) s << ',' << int(a);
  char crc[16];
  std::snprintf(crc, sizeof(crc), "%08x", r.jpeg_crc32);
  s << ',' << r.step_index << ',' << calib::CsvCell(r.step_name) << ',' << r.placement_index << ',' << r.jpeg_bytes
    << ',' << crc << '\n';
  return s.str();
}

std::string PlacementLine(const PlacementRecord& p) {
  const Eigen::Quaterniond q(p.base_from_target.rotation());
  const Eigen::Vector3d t = p.base_from_target.translation();
  std::ostringstream s;
  s << p.placement_index << ',' << p.step_index << ',' << calib::CsvCell(p.target) << ',' << Fmt(p.distance_m) << ','
    << Fmt(t.x()) << ',' << Fmt(t.y()) << ',' << Fmt(t.z()) << ',' << Fmt(q.x()) << ',' << Fmt(q.y()) << ','
    << Fmt(q.z()) << ',' << Fmt(q.w()) << ',' << calib::CsvCell(p.source) << ',' << calib::CsvCell(p.answer) << ','
    << p.stamp_ns << '\n';
  return s.str();
}

PlacementRecord ParsePlacementRow(const std::vector<std::string>& f, const std::string& where) {
  if (static_cast<int>(f.size()) != kPlacementsCsvFields)
    throw std::runtime_error(where + ": " + std::to_string(f.size()) + " fields, expected " +
                             std::to_string(kPlacementsCsvFields));
  PlacementRecord p;
  p.placement_index = static_cast<int>(ParseInt(f[0], where + " field placement_index", 0, INT32_MAX));
  p.step_index = static_cast<int>(ParseInt(f[1], where + " field step_index", -1, INT32_MAX));
  p.target = f[2];
  p.distance_m = ParseDouble(f[3], where + " field distance_m", 0, 1e3);
  Eigen::Vector3d t(ParseDouble(f[4], where + " field tx_m"),
                    ParseDouble(f[5], where + " field ty_m"),
                    ParseDouble(f[6], where + " field tz_m"));
  Eigen::Quaterniond q(ParseDouble(f[10], where + " field qw"),
                       ParseDouble(f[7], where + " field qx"),
                       ParseDouble(f[8], where + " field qy"),
                       ParseDouble(f[9], where + " field qz"));
  if (std::abs(q.norm() - 1) > 1e-6)
    throw std::runtime_error(where + " fields qx..qw: norm " + io::FormatNumber(q.norm()) +
                             " is not a unit quaternion");
  p.base_from_target = Eigen::Isometry3d::Identity();
  p.base_from_target.linear() = q.normalized().toRotationMatrix();
  p.base_from_target.translation() = t;
  p.source = f[11];
  p.answer = f[12];
  p.stamp_ns = ParseInt(f[13], where + " field stamp_ns");
  return p;
}

std::string StepLine(const StepRecord& s) {
  std::ostringstream o;
  o << s.step_index << ',' << calib::CsvCell(s.step_name) << ',' << calib::CsvCell(s.kind) << ','
    << calib::CsvCell(s.status) << ',' << s.start_ns << ',' << s.end_ns << ',' << s.num_frames << '\n';
  return o.str();
}

StepRecord ParseStepRow(const std::vector<std::string>& f, const std::string& where) {
  if (static_cast<int>(f.size()) != kStepsCsvFields)
    throw std::runtime_error(where + ": " + std::to_string(f.size()) + " fields, expected " +
                             std::to_string(kStepsCsvFields));
  StepRecord s;
  s.step_index = static_cast<int>(ParseInt(f[0], where + " field step_index", 0, INT32_MAX));
  s.step_name = f[1];
  s.kind = f[2];
  s.status = f[3];
  s.start_ns = ParseInt(f[4], where + " field start_ns");
  s.end_ns = ParseInt(f[5], where + " field end_ns");
  s.num_frames = ParseInt(f[6], where + " field num_frames", 0);
  return s;
}

// The header of a table as cells.
std::vector<std::string> HeaderCells(const char* header) { return calib::SplitCsvLine(header, false, header); }

// Throws "PATH:1: header is '...', expected '...'" unless the table has the expected header (or none).
void CheckHeader(const calib::CsvTable& t, const char* header) {
  if (t.Header().empty() || t.Header() == HeaderCells(header)) return;
  std::string got;
  for (const std::string& h : t.Header()) {
    if (!got.empty()) got.push_back(',');
    got += io::Printable(h);
  }
  throw std::runtime_error(t.Source() + ":1: header is '" + got + "', expected '" + header + "'");
}

// Header check + every complete row parsed by `parse`; a partial tail is ignored.
template <typename R, typename Parse>
std::vector<R> ReadTable(const std::string& path, const char* header, Parse parse) {
  const calib::CsvTable t = ReadAppendedCsv(path);
  CheckHeader(t, header);
  std::vector<R> out;
  for (size_t r = 0; r < t.NumRows(); ++r) out.push_back(parse(t.Cells(r), t.Where(r)));
  return out;
}

// A row as one CSV line (cells quoted where needed).
std::string CsvLine(const std::vector<std::string>& cells) {
  std::string line;
  for (size_t i = 0; i < cells.size(); ++i) {
    if (i) line.push_back(',');
    line += calib::CsvCell(cells[i]);
  }
  line.push_back('\n');
  return line;
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

// ---------------------------------------------------------------- writer

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
  CheckHeader(frames, kFramesCsvHeader);
  std::string out = std::string(kFramesCsvHeader) + "\n";
  for (size_t i = 0; i < frames.NumRows(); ++i) {
    FrameRecord r = ParseFrameRow(frames.Cells(i), frames.Where(i));
    if (r.step_index >= first_step) {
      superseded.insert(r.frame_index);
      r.step_name = "superseded:" + r.step_name;
      r.step_index = -1;
    }
    out += FrameLine(r);
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
    const std::string header_line = CsvLine(t.Header());
    std::string keep = header_line, gone;
    int64_t num_gone = 0;
    for (size_t i = 0; i < t.NumRows(); ++i) {
      const int64_t key = t.Integer(i, key_column, INT64_MIN, INT64_MAX);
      const bool drop = by_step ? key >= first_step : superseded.count(key) > 0;
      (drop ? gone : keep) += CsvLine(t.Cells(i));
      num_gone += drop;
    }
    if (gone.empty()) continue;
    fs::create_directories(dir / "superseded");
    const fs::path side = dir / "superseded" / name;
    const bool fresh = !fs::exists(side) || fs::file_size(side) == 0;
    const std::string previous = fresh ? header_line : ReadWholeFile(side.string());
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
  AppendLine(Open("frames.csv", kFramesCsvHeader), "frames.csv", FrameLine(record));
  return next_frame_index_++;
}

int DatasetWriter::AppendPlacement(PlacementRecord placement) {
  placement.placement_index = next_placement_index_;
  AppendLine(Open("placements.csv", kPlacementsCsvHeader), "placements.csv", PlacementLine(placement));
  placements_.push_back(placement);
  return next_placement_index_++;
}

void DatasetWriter::AppendStep(const StepRecord& step) {
  AppendLine(Open("steps.csv", kStepsCsvHeader), "steps.csv", StepLine(step));
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

// ---------------------------------------------------------------- reading and checking

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
  const nlohmann::json j = io::ParseJsonStrict(ReadWholeFile(path), path);
  if (!j.is_object() || j.value("format", "") != kDatasetFormat)
    throw std::runtime_error(path + ": field 'format' is not '" + std::string(kDatasetFormat) + "'");
  return j;
}

std::vector<FrameRecord> ReadFramesCsv(const std::string& dir) {
  return ReadTable<FrameRecord>((fs::path(dir) / "frames.csv").string(), kFramesCsvHeader, ParseFrameRow);
}
std::vector<PlacementRecord> ReadPlacementsCsv(const std::string& dir) {
  return ReadTable<PlacementRecord>(
      (fs::path(dir) / "placements.csv").string(), kPlacementsCsvHeader, ParsePlacementRow);
}
std::vector<StepRecord> ReadStepsCsv(const std::string& dir) {
  return ReadTable<StepRecord>((fs::path(dir) / "steps.csv").string(), kStepsCsvHeader, ParseStepRow);
}

std::vector<uint8_t> ReadFrameJpeg(const std::string& dir, int64_t frame_index) {
  const std::string data = ReadWholeFile(FramePath(dir, frame_index));
  return std::vector<uint8_t>(data.begin(), data.end());
}

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
    CheckHeader(frames, kFramesCsvHeader);
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
      r = ParseFrameRow(frames.Cells(i), where);
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
      CheckHeader(t, header);
      for (size_t i = 0; i < t.NumRows(); ++i) parse(t.Cells(i), t.Where(i));
    } catch (const std::exception& e) {
      error(e.what());
    }
  };
  check_table("placements.csv", kPlacementsCsvHeader, ParsePlacementRow);
  check_table("steps.csv", kStepsCsvHeader, ParseStepRow);
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
      const std::string text = ReadWholeFile(e.path().string());
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
