// Protocol file parsing: a YAML text to a Protocol (targets, tag targets, steps with `repeat`
// expanded under the kMaxPlanSteps cap), a protocol file, and the targets a dataset's protocols
// define.
#include <algorithm>
#include <fstream>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "io/strict_number.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/protocol_fields.h"

namespace owlcal::protocols {
namespace {

using internal::Fields;

calib::TargetDefinition ParseTarget(const YAML::Node& node, const std::string& name, const std::string& source) {
  Fields f(node, source, "targets." + name);
  calib::TargetDefinition t;
  t.id = name;
  t.kind = f.Enum("target_type",
                  calib::TargetKind::kChessboard,
                  {{"chessboard", calib::TargetKind::kChessboard},
                   {"aprilgrid", calib::TargetKind::kAprilGrid},
                   {"fixation", calib::TargetKind::kFixation}});
  if (t.kind == calib::TargetKind::kChessboard) {
    t.cols = f.PositiveInt("cols", t.cols, 2);
    t.rows = f.PositiveInt("rows", t.rows, 2);
    t.square_m = f.PositiveDouble("square_size_m", t.square_m);
  } else if (t.kind == calib::TargetKind::kAprilGrid) {
    t.tag_cols = f.PositiveInt("tagCols", t.tag_cols);
    t.tag_rows = f.PositiveInt("tagRows", t.tag_rows);
    t.tag_size_m = f.PositiveDouble("tagSize", t.tag_size_m);
    t.tag_spacing = f.PositiveDouble("tagSpacing", t.tag_spacing, true);
    t.first_id = f.PositiveInt("first_id", t.first_id, 0);
    t.family = f.Value<std::string>("family", t.family);
  } else {
    t.fixation_radius_m = f.PositiveDouble("fixation_radius_m", t.fixation_radius_m);
  }
  f.RejectUnknown();
  return t;
}

Step ParseStep(
    const std::string& kind, const YAML::Node& body, const std::string& source, const std::string& where, int line) {
  Step s;
  Fields f(body.IsNull() ? YAML::Node(YAML::NodeType::Map) : body, source, where, line);
  s.name = f.Value<std::string>("name", "");
  s.params = internal::ParseStepParams(kind, f, source, where);
  f.RejectUnknown();
  return s;
}

// Steps `list` expands to (repeats multiplied out, saturating above kMaxPlanSteps).
int64_t CountSteps(const YAML::Node& list, const std::string& source, int depth) {
  if (!list || !list.IsSequence()) throw ProtocolError(source + ": field 'steps': expected a list of steps");
  if (depth > 4) throw ProtocolError(source + ": repeat nested too deeply");
  int64_t n = 0;
  for (size_t i = 0; i < list.size() && n <= kMaxPlanSteps; ++i) {
    const YAML::Node item = list[i];
    if (item.IsMap() && item.size() == 1 && item.begin()->first.IsScalar() &&
        item.begin()->first.Scalar() == "repeat" && item.begin()->second.IsMap()) {
      const YAML::Node body = item.begin()->second;
      int times = 1;
      if (body["times"] && body["times"].IsScalar() &&
          !io::CheckInt(body["times"].Scalar(), 1, kMaxPlanInt, &times).empty())
        times = 1;  // ParseSteps names the bad value
      n += std::min<int64_t>(kMaxPlanSteps + 1, times * CountSteps(body["steps"], source, depth + 1));
    } else {
      ++n;
    }
  }
  return std::min<int64_t>(n, kMaxPlanSteps + 1);
}

void ParseSteps(const YAML::Node& list, const std::string& source, const std::string& prefix, Protocol* p, int depth) {
  if (!list || !list.IsSequence()) throw ProtocolError(source + ": field 'steps': expected a list of steps");
  if (depth > 4) throw ProtocolError(source + ": repeat nested too deeply");
  for (size_t i = 0; i < list.size(); ++i) {
    const YAML::Node item = list[i];
    const int line = item.Mark().line;  // 0-based, -1 unknown
    const std::string at = source + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": ";
    const std::string where = "step " + prefix + std::to_string(i);
    if (!item.IsMap() || item.size() != 1)
      throw ProtocolError(at + where + ": expected one key naming the step kind, e.g. '- sweep: {...}'");
    const std::string kind = item.begin()->first.as<std::string>();
    const YAML::Node body = item.begin()->second;
    const std::string context = where + " (" + kind + ")";
    if (kind == "repeat") {
      Fields f(body, source, context, line);
      const int times = f.PositiveInt("times", 1);
      const YAML::Node inner = f.Get("steps");
      f.Value<std::string>("name", "");
      f.RejectUnknown();
      // The plan is expanded in memory: cap its size before expanding (a repeat of 2e9, or
      // nested repeats of 1000, ended in std::bad_alloc).
      const int64_t each = CountSteps(inner, source, depth + 1);
      if (each * times > kMaxPlanSteps - static_cast<int64_t>(p->steps.size()))
        f.Fail("times",
               std::to_string(times) + " x " + std::to_string(each) + " steps would make the protocol longer than " +
                   std::to_string(kMaxPlanSteps) + " steps");
      for (int k = 0; k < times; ++k) {
        const size_t before = p->steps.size();
        ParseSteps(inner, source, prefix + std::to_string(i) + ".", p, depth + 1);
        const std::string suffix = std::to_string(k + 1);
        for (size_t j = before; j < p->steps.size(); ++j) {
          p->steps[j].name.push_back('#');
          p->steps[j].name.append(suffix);
        }
      }
      continue;
    }
    Step s = ParseStep(kind, body, source, context, line);
    s.file = source;
    s.file_index = static_cast<int>(i);
    s.file_line = line + 1;
    if (s.name.empty()) s.name = kind + std::to_string(p->steps.size());
    p->steps.push_back(std::move(s));
  }
}

}  // namespace

Protocol ParseProtocolYaml(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ProtocolError(source + ": not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw ProtocolError(source + ": expected a map with name, target and steps");
  Fields f(root, source, "");
  Protocol p;
  p.text = yaml_text;
  p.name = f.Scalar("name");
  if (p.name.empty()) f.Fail("name", "must not be empty");
  p.description = f.Value<std::string>("description", "");
  p.target = f.Value<std::string>("target", "");
  p.target_description = f.Value<std::string>("target_description", "");
  if (f.Has("targets")) {
    YAML::Node t = f.Get("targets");
    if (!t.IsMap()) f.Fail("targets", "expected a map name -> target definition");
    for (const auto& kv : t) {
      const std::string name = kv.first.as<std::string>();
      p.targets[name] = ParseTarget(kv.second, name, source);
    }
  }
  if (f.Has("tag_targets")) {
    YAML::Node t = f.Get("tag_targets");
    if (!t.IsSequence()) f.Fail("tag_targets", "expected a list of target names");
    for (const auto& n : t) {
      const std::string name = n.as<std::string>();
      const auto it = p.targets.find(name);
      if (it == p.targets.end()) f.Fail("tag_targets", "'" + name + "' is not one of `targets`");
      if (it->second.kind != calib::TargetKind::kAprilGrid) f.Fail("tag_targets", "'" + name + "' is not an aprilgrid");
      if (name == p.target) f.Fail("tag_targets", "'" + name + "' is the protocol's `target`");
      if (std::find(p.tag_targets.begin(), p.tag_targets.end(), name) != p.tag_targets.end())
        f.Fail("tag_targets", "'" + name + "' is listed twice");
      p.tag_targets.push_back(name);
    }
  }
  ParseSteps(f.Get("steps"), source, "", &p, 0);
  f.RejectUnknown();
  return p;
}

Protocol LoadProtocolFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ProtocolError(path + ": cannot open protocol file");
  std::ostringstream s;
  s << in.rdbuf();
  Protocol p = ParseProtocolYaml(s.str(), path);
  p.file = path;
  return p;
}

std::map<std::string, calib::TargetDefinition> TargetsOfDataset(const std::string& dataset) {
  std::map<std::string, calib::TargetDefinition> out;
  const nlohmann::json m = ReadManifest(dataset);
  for (const auto& p : m.value("protocols", nlohmann::json::array())) {
    if (!p.contains("text") || !p["text"].is_string()) continue;
    for (const auto& [name, def] : ParseProtocolYaml(p["text"].get<std::string>(), dataset + "/manifest.json").targets)
      out[name] = def;
  }
  return out;
}

}  // namespace owlcal::protocols
