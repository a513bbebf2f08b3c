#include "calib/target_file.h"

#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

namespace owlcal::calib {
namespace {

[[noreturn]] void Fail(const std::string& source, const std::string& key, const std::string& what) {
  throw std::runtime_error("target file " + source + ": " + key + ": " + what);
}

template <typename T>
T Get(const YAML::Node& root, const std::string& source, const std::string& key) {
  if (!root[key]) Fail(source, key, "missing");
  try {
    return root[key].as<T>();
  } catch (const YAML::Exception&) {
    Fail(source, key, "bad value '" + YAML::Dump(root[key]) + "'");
  }
}

template <typename T>
T GetOr(const YAML::Node& root, const std::string& source, const std::string& key, T dflt) {
  if (!root[key]) return dflt;
  return Get<T>(root, source, key);
}

}  // namespace

TargetFile ParseTargetYaml(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("target file " + source + ": not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw std::runtime_error("target file " + source + ": expected a map of keys");
  TargetFile out;
  TargetDefinition& t = out.target;
  const std::string type = Get<std::string>(root, source, "target_type");
  t.id = GetOr<std::string>(root, source, "id", "board");
  out.unit = GetOr<std::string>(root, source, "unit", "m");
  std::set<std::string> known = {"target_type", "id", "unit"};
  if (type == "chessboard" || type == "checkerboard") {
    t.kind = TargetKind::kChessboard;
    // Kalibr spells them targetCols/targetRows/rowSpacingMeters; accept both spellings.
    t.cols = root["cols"] ? Get<int>(root, source, "cols") : Get<int>(root, source, "targetCols");
    t.rows = root["rows"] ? Get<int>(root, source, "rows") : Get<int>(root, source, "targetRows");
    if (root["square_size_m"]) {
      t.square_m = Get<double>(root, source, "square_size_m");
    } else if (root["square_size"]) {
      t.square_m = Get<double>(root, source, "square_size");
    } else if (root["rowSpacingMeters"]) {
      t.square_m = Get<double>(root, source, "rowSpacingMeters");
    } else {
      Fail(source, "square_size_m", "missing (give square_size_m, or square_size with unit)");
    }
    known.insert({"cols", "rows", "targetCols", "targetRows", "square_size_m", "square_size", "rowSpacingMeters",
                  "colSpacingMeters"});
    if (t.cols < 2 || t.cols > 100) Fail(source, "cols", "must be 2..100 inner corners, got " + std::to_string(t.cols));
    if (t.rows < 2 || t.rows > 100) Fail(source, "rows", "must be 2..100 inner corners, got " + std::to_string(t.rows));
    if (!(t.square_m > 0)) Fail(source, "square_size_m", "must be > 0, got " + std::to_string(t.square_m));
  } else if (type == "aprilgrid") {
    t.kind = TargetKind::kAprilGrid;
    t.tag_cols = Get<int>(root, source, "tagCols");
    t.tag_rows = Get<int>(root, source, "tagRows");
    t.tag_size_m = Get<double>(root, source, "tagSize");
    t.tag_spacing = Get<double>(root, source, "tagSpacing");
    t.first_id = GetOr<int>(root, source, "first_id", 0);
    t.family = GetOr<std::string>(root, source, "family", "tag36h11");
    known.insert({"tagCols", "tagRows", "tagSize", "tagSpacing", "first_id", "family", "codeOffset"});
    if (t.tag_cols < 1 || t.tag_cols > 100) Fail(source, "tagCols", "must be 1..100, got " + std::to_string(t.tag_cols));
    if (t.tag_rows < 1 || t.tag_rows > 100) Fail(source, "tagRows", "must be 1..100, got " + std::to_string(t.tag_rows));
    if (!(t.tag_size_m > 0)) Fail(source, "tagSize", "must be > 0, got " + std::to_string(t.tag_size_m));
    if (!(t.tag_spacing >= 0)) Fail(source, "tagSpacing", "must be >= 0, got " + std::to_string(t.tag_spacing));
    if (t.first_id < 0) Fail(source, "first_id", "must be >= 0, got " + std::to_string(t.first_id));
    if (t.family != "tag36h11" && t.family != "tag25h9" && t.family != "tag16h5")
      Fail(source, "family", "unsupported '" + t.family + "' (tag36h11, tag25h9, tag16h5)");
  } else {
    Fail(source, "target_type", "unknown '" + type + "' (chessboard or aprilgrid)");
  }
  for (const auto& kv : root) {
    const std::string key = kv.first.as<std::string>();
    if (!known.count(key)) Fail(source, key, "unknown key");
  }
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
  std::ofstream f(path);
  if (!f) throw std::runtime_error("cannot write target file " + path);
  f << e.c_str() << "\n";
  if (!f) throw std::runtime_error("error writing target file " + path);
}

}  // namespace owlcal::calib
