// The rows of a dataset's own tables, parsed strictly and written back: frames.csv, placements.csv
// and steps.csv (protocols/dataset.h documents their columns), the header check and a row as one
// CSV line.
#include "protocols/dataset_rows.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "calib/csv.h"
#include "io/strict_number.h"

namespace owlcal::protocols::internal {
namespace {

constexpr int kFramesCsvFields = 18;
constexpr int kPlacementsCsvFields = 14;
constexpr int kStepsCsvFields = 7;

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

// The header of a table as cells.
std::vector<std::string> HeaderCells(const char* header) { return calib::SplitCsvLine(header, false, header); }

}  // namespace

std::string ReadWholeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
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

}  // namespace owlcal::protocols::internal
