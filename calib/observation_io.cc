#include "calib/observation_io.h"

#include "calib/csv.h"
#include "io/atomic_file.h"

#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace owlcal::calib {
namespace {

constexpr const char* kHeader =
    "frame_index,eye,target_id,corner_id,u_px,v_px,x_m,y_m,z_m,Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,"
    "approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,stamp_ns";
constexpr int kNumFields = 20;
constexpr const char* kFieldNames[kNumFields] = {
    "frame_index", "eye",         "target_id",   "corner_id",   "u_px",          "v_px",    "x_m",
    "y_m",         "z_m",         "Rx_us",       "Ry_us",       "Lx_us",         "Ly_us",   "Neck_us",
    "approach_Rx", "approach_Ry", "approach_Lx", "approach_Ly", "approach_Neck", "stamp_ns"};

void WriteRows(std::ostream& f, const std::vector<CornerObservation>& obs) {
  char buf[64];
  auto num = [&](double v) {
    std::snprintf(buf, sizeof(buf), "%.17g", v);
    return std::string(buf);
  };
  for (const CornerObservation& o : obs) {
    if (o.target_id.find_first_of(",\n\"") != std::string::npos)
      throw std::invalid_argument("observation target_id '" + o.target_id + "' contains a comma, quote or newline");
    f << o.frame_index << ',' << (o.eye == 0 ? "left" : "right") << ',' << o.target_id << ',' << o.corner_id << ','
      << num(o.pixel.x()) << ',' << num(o.pixel.y()) << ',' << num(o.point_in_target.x()) << ','
      << num(o.point_in_target.y()) << ',' << num(o.point_in_target.z());
    for (int v : o.pwm_us) f << ',' << v;
    for (int8_t a : o.approach) f << ',' << int(a);
    f << ',' << o.stamp_ns << '\n';
  }
}

// Bounds of the numeric columns: pixels within +-1e5 px (a Ceres residual squares them), board
// points within +-1 km, pulse widths four digits, ids that fit an int.
constexpr double kMaxAbsPixel = 1e5;
constexpr double kMaxAbsPoint_m = 1e3;

CornerObservation ParseRow(const CsvTable& t, size_t r) {
  CornerObservation o;
  o.frame_index = t.Int(r, "frame_index", 0, INT32_MAX);
  const std::string& eye = t.Text(r, "eye");
  if (eye == "left" || eye == "0") {
    o.eye = 0;
  } else if (eye == "right" || eye == "1") {
    o.eye = 1;
  } else {
    throw std::runtime_error(t.Where(r) + ": column eye = '" + io::Printable(eye) + "' is not left or right");
  }
  o.target_id = t.Text(r, "target_id");
  if (o.target_id.empty()) throw std::runtime_error(t.Where(r) + ": column target_id is empty");
  o.corner_id = t.Int(r, "corner_id", 0, INT32_MAX);
  o.pixel = Eigen::Vector2d(t.Number(r, "u_px", -kMaxAbsPixel, kMaxAbsPixel),
                            t.Number(r, "v_px", -kMaxAbsPixel, kMaxAbsPixel));
  o.point_in_target = Eigen::Vector3d(t.Number(r, "x_m", -kMaxAbsPoint_m, kMaxAbsPoint_m),
                                      t.Number(r, "y_m", -kMaxAbsPoint_m, kMaxAbsPoint_m),
                                      t.Number(r, "z_m", -kMaxAbsPoint_m, kMaxAbsPoint_m));
  for (int i = 0; i < models::kNumServos; ++i) {
    o.pwm_us[i] = t.Int(r, kFieldNames[9 + i], 0, 9999);
    o.approach[i] = static_cast<int8_t>(t.Int(r, kFieldNames[14 + i], -1, 1));
  }
  o.stamp_ns = t.Integer(r, "stamp_ns", INT64_MIN, INT64_MAX);
  return o;
}

}  // namespace

void WriteObservationsCsv(const std::string& path, const std::vector<CornerObservation>& obs) {
  std::ostringstream f;
  f << kHeader << '\n';
  WriteRows(f, obs);
  io::WriteFileAtomic(path, f.str());
}

void AppendObservationsCsv(const std::string& path, const std::vector<CornerObservation>& obs) {
  bool need_header = true;
  {
    std::ifstream in(path, std::ios::ate);
    if (in && in.tellg() > 0) need_header = false;
  }
  std::ofstream f(path, std::ios::app);
  if (!f) throw std::runtime_error("cannot append to observation file " + path);
  if (need_header) f << kHeader << '\n';
  WriteRows(f, obs);
  f.close();  // an append cannot be atomic, but its flush and close are checked
  if (!f) throw std::runtime_error("error appending to observation file " + path);
}

std::vector<CornerObservation> ReadObservationsCsv(const std::string& path) {
  const CsvTable t = CsvTable::Read(path, {.allow_partial_tail = true});
  for (const char* name : kFieldNames) t.Column(name);
  if (t.Header().size() != kNumFields) {
    for (const std::string& h : t.Header()) {
      bool known = false;
      for (const char* name : kFieldNames) known = known || h == name;
      if (!known)
        throw std::runtime_error(path + ":1: unknown column '" + io::Printable(h) + "' (header: " + kHeader + ")");
    }
  }
  if (t.DroppedPartialTail())
    std::cerr << "warning: " << path << ": truncated last line (no line break, incomplete) dropped\n";
  std::vector<CornerObservation> out;
  out.reserve(t.NumRows());
  // A corner seen twice in one view (frame, eye, target) would count twice and shrink every
  // sigma by about 1/sqrt(2): refused, naming both lines.
  std::unordered_map<std::string, size_t> row_of_corner;
  for (size_t r = 0; r < t.NumRows(); ++r) {
    out.push_back(ParseRow(t, r));
    const CornerObservation& o = out.back();
    const std::string key = std::to_string(o.frame_index) + "," + std::to_string(o.eye) + "," +
                            std::to_string(o.corner_id) + "," + o.target_id;
    const auto [it, fresh] = row_of_corner.emplace(key, r);
    if (!fresh) {
      throw std::runtime_error(t.Where(r) + ": corner " + std::to_string(o.corner_id) + " of target '" +
                               io::Printable(o.target_id) + "' in frame " + std::to_string(o.frame_index) + ", " +
                               (o.eye == 0 ? "left" : "right") + " eye, is already on " + t.Where(it->second) +
                               ": a duplicated row would count twice and shrink every sigma");
    }
  }
  return out;
}

}  // namespace owlcal::calib
