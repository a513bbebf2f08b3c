#include "calib/target_file.h"

#include <fstream>
#include <initializer_list>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "io/atomic_file.h"
#include "io/strict_number.h"
#include "io/yaml_fields.h"

namespace owlcal::calib {
namespace {

// The value of whichever spelling is present (Kalibr's or owlcal's); both at once is an error.
std::string OneSpelling(const io::YamlFields& f, std::initializer_list<const char*> keys) {
  std::string found;
  for (const char* k : keys) {
    if (!f.Has(k)) continue;
    if (!found.empty()) f.Fail(k, "says the same as " + found + "; give one of them");
    found = k;
  }
  return found;
}

}  // namespace

TargetFile ParseTargetYaml(const std::string& yaml_text, const std::string& source) {
  io::YamlFields f(io::LoadYamlText(yaml_text, source), source);
  TargetFile out;
  TargetDefinition& t = out.target;
  const std::string type = f.String("target_type");
  t.id = f.String("id", "board");
  if (t.id.empty()) f.Fail("id", "must not be empty");
  out.unit = f.String("unit", "m");
  if (out.unit.empty()) f.Fail("unit", "must not be empty");
  // Sizes in the file's unit: positive and below 1000 units (a board is not a kilometre wide).
  constexpr double kMaxSize = 1e3;
  if (type == "chessboard" || type == "checkerboard") {
    t.kind = TargetKind::kChessboard;
    // Kalibr spells them targetCols/targetRows/rowSpacingMeters; accept both spellings.
    const std::string cols = OneSpelling(f, {"cols", "targetCols"});
    const std::string rows = OneSpelling(f, {"rows", "targetRows"});
    t.cols = f.Int(cols.empty() ? "cols" : cols, 2, 100);
    t.rows = f.Int(rows.empty() ? "rows" : rows, 2, 100);
    const std::string square = OneSpelling(f, {"square_size_m", "square_size", "rowSpacingMeters"});
    if (square.empty()) f.Fail("square_size_m", "missing (give square_size_m, or square_size with unit)");
    t.square_m = f.Number(square, 1e-9, kMaxSize);
    if (f.Has("colSpacingMeters") && f.Number("colSpacingMeters", 1e-9, kMaxSize) != t.square_m)
      f.Fail("colSpacingMeters", "differs from the row spacing (owlcal's chessboards have square cells)");
  } else if (type == "aprilgrid") {
    t.kind = TargetKind::kAprilGrid;
    t.tag_cols = f.Int("tagCols", 1, 100);
    t.tag_rows = f.Int("tagRows", 1, 100);
    t.tag_size_m = f.Number("tagSize", 1e-9, kMaxSize);
    t.tag_spacing = f.Number("tagSpacing", 0, 10);
    t.first_id = f.Int("first_id", 0, 0, 100000);
    t.family = f.String("family", "tag36h11");
    if (t.family != "tag36h11" && t.family != "tag25h9" && t.family != "tag16h5")
      f.Fail("family", "= '" + io::Printable(t.family) + "' is not supported (tag36h11, tag25h9, tag16h5)");
    if (f.Has("codeOffset")) f.Int("codeOffset", 0, 100000);  // Kalibr's, not used
  } else {
    f.Fail("target_type", "= '" + io::Printable(type) + "' is unknown (chessboard or aprilgrid)");
  }
  f.RejectUnknown();
  return out;
}

TargetFile LoadTargetFileWithUnit(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot open target file " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ParseTargetYaml(ss.str(), path);
}

TargetDefinition LoadTargetFile(const std::string& path) { return LoadTargetFileWithUnit(path).target; }

void SaveTargetFile(const TargetDefinition& t, const std::string& path, const std::string& unit) {
  YAML::Emitter e;
  e.SetDoublePrecision(17);
  e << YAML::BeginMap;
  e << YAML::Key << "id" << YAML::Value << t.id;
  switch (t.kind) {
    case TargetKind::kChessboard:
      e << YAML::Key << "target_type" << YAML::Value << "chessboard";
      e << YAML::Key << "cols" << YAML::Value << t.cols;
      e << YAML::Key << "rows" << YAML::Value << t.rows;
      e << YAML::Key << (unit == "m" ? "square_size_m" : "square_size") << YAML::Value << t.square_m;
      break;
    case TargetKind::kAprilGrid:
      e << YAML::Key << "target_type" << YAML::Value << "aprilgrid";
      e << YAML::Key << "tagCols" << YAML::Value << t.tag_cols;
      e << YAML::Key << "tagRows" << YAML::Value << t.tag_rows;
      e << YAML::Key << "tagSize" << YAML::Value << t.tag_size_m;
      e << YAML::Key << "tagSpacing" << YAML::Value << t.tag_spacing;
      e << YAML::Key << "first_id" << YAML::Value << t.first_id;
      e << YAML::Key << "family" << YAML::Value << t.family;
      break;
    case TargetKind::kFixation:
      throw std::runtime_error("target file " + path + ": target_type: fixation targets are not saved as files");
  }
  e << YAML::Key << "unit" << YAML::Value << unit;
  e << YAML::EndMap;
  io::WriteFileAtomic(path, std::string(e.c_str()) + "\n");
}

}  // namespace owlcal::calib
