#include "calib/observation_io.h"

#include "calib/csv.h"

#include <charconv>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <stdexcept>

namespace owlcal::calib {
namespace {

constexpr const char* kHeader =
    "frame_index,eye,target_id,corner_id,u_px,v_px,x_m,y_m,z_m,Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,"
    "approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,stamp_ns";
constexpr int kNumFields = 20;
constexpr const char* kFieldNames[kNumFields] = {
    "frame_index", "eye",        "target_id",   "corner_id",   "u_px",        "v_px",          "x_m",
    "y_m",         "z_m",        "Rx_us",       "Ry_us",       "Lx_us",       "Ly_us",         "Neck_us",
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


template <typename T>
bool ParseNum(const std::string& s, T* v) {
  if constexpr (std::is_floating_point_v<T>) {
    if (s.empty()) return false;
    char* end = nullptr;
    *v = std::strtod(s.c_str(), &end);
    return end == s.c_str() + s.size();
  } else {
    const auto r = std::from_chars(s.data(), s.data() + s.size(), *v);
    return !s.empty() && r.ec == std::errc() && r.ptr == s.data() + s.size();
  }
}

// Parses one row; on failure returns the index of the bad field (or -1 for a wrong count).
bool ParseRow(const std::vector<std::string>& f, CornerObservation* o, int* bad_field) {
  *bad_field = -1;
  if (int(f.size()) != kNumFields) return false;
  auto fail = [&](int i) {
    *bad_field = i;
    return false;
  };
  if (!ParseNum(f[0], &o->frame_index)) return fail(0);
  if (f[1] == "left" || f[1] == "0") {
    o->eye = 0;
  } else if (f[1] == "right" || f[1] == "1") {
    o->eye = 1;
  } else {
    return fail(1);
  }
  if (f[2].empty()) return fail(2);
  o->target_id = f[2];
  if (!ParseNum(f[3], &o->corner_id)) return fail(3);
  double d[5];
  for (int i = 0; i < 5; ++i)
    if (!ParseNum(f[4 + i], &d[i])) return fail(4 + i);
  o->pixel = Eigen::Vector2d(d[0], d[1]);
  // point_in_target: fields 6..8
  double p[3];
  for (int i = 0; i < 3; ++i)
    if (!ParseNum(f[6 + i], &p[i])) return fail(6 + i);
  o->point_in_target = Eigen::Vector3d(p[0], p[1], p[2]);
  for (int i = 0; i < 5; ++i)
    if (!ParseNum(f[9 + i], &o->pwm_us[i])) return fail(9 + i);
  for (int i = 0; i < 5; ++i) {
    int a = 0;
    if (!ParseNum(f[14 + i], &a) || a < -1 || a > 1) return fail(14 + i);
    o->approach[i] = int8_t(a);
  }
  if (!ParseNum(f[19], &o->stamp_ns)) return fail(19);
  return true;
}

}  // namespace

void WriteObservationsCsv(const std::string& path, const std::vector<CornerObservation>& obs) {
  std::ofstream f(path, std::ios::trunc);
  if (!f) throw std::runtime_error("cannot write observation file " + path);
  f << kHeader << '\n';
  WriteRows(f, obs);
  if (!f) throw std::runtime_error("error writing observation file " + path);
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
  if (!f) throw std::runtime_error("error appending to observation file " + path);
}

std::vector<CornerObservation> ReadObservationsCsv(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot open observation file " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string text = ss.str();
  std::vector<std::string> lines;
  size_t start = 0;
  while (start < text.size()) {
    size_t nl = text.find('\n', start);
    if (nl == std::string::npos) {
      lines.push_back(text.substr(start));
      start = text.size();
    } else {
      lines.push_back(text.substr(start, nl - start));
      start = nl + 1;
    }
  }
  const bool ends_with_newline = !text.empty() && text.back() == '\n';
  if (lines.empty()) throw std::runtime_error(path + ":1: empty observation file (no header row)");
  std::string header = lines[0];
  if (!header.empty() && header.back() == '\r') header.pop_back();
  if (header != kHeader) throw std::runtime_error(path + ":1: header: expected '" + std::string(kHeader) + "'");
  std::vector<CornerObservation> out;
  for (size_t i = 1; i < lines.size(); ++i) {
    const std::string& line = lines[i];
    if (line.empty() || line == "\r") continue;
    CornerObservation o;
    int bad = -1;
    const std::vector<std::string> fields = SplitCsvLine(line);
    if (ParseRow(fields, &o, &bad)) {
      out.push_back(o);
      continue;
    }
    const bool last = i + 1 == lines.size();
    if (last && !ends_with_newline) {
      std::cerr << "warning: " << path << ":" << i + 1 << ": truncated last line dropped\n";
      break;
    }
    const std::string where = path + ":" + std::to_string(i + 1) + ": ";
    if (bad < 0)
      throw std::runtime_error(where + "expected " + std::to_string(kNumFields) + " fields, got " +
                               std::to_string(fields.size()));
    throw std::runtime_error(where + kFieldNames[bad] + ": bad value '" + fields[bad] + "'");
  }
  return out;
}

}  // namespace owlcal::calib
