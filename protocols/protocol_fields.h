#pragma once
// The reader of a protocol file's YAML maps and the step parser (internal to protocols/): Fields
// reads the fields of one map, naming the file, line and step in every error and rejecting unknown
// keys; ParseStepParams (protocols/protocol_steps.cc) reads one step's fields by its kind.
#include <initializer_list>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "io/strict_number.h"
#include "protocols/protocol.h"

namespace owlcal::protocols::internal {

// Reads fields of one YAML map, naming the context in every error and rejecting unknown keys.
class Fields {
 public:
  // Messages read "SOURCE:LINE: WHERE: field 'KEY': ..." (LINE of the field, else of the map).
  // fallback_line (0-based) stands for a node without a position (an empty step body).
  Fields(const YAML::Node& node, std::string source, std::string where, int fallback_line = -1)
      : node_(node), source_(std::move(source)), where_(std::move(where)), fallback_line_(fallback_line) {
    if (!node_.IsMap()) throw ProtocolError(At(node_) + "expected a map of fields");
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& what) const {
    const YAML::Node n = node_[key];
    throw ProtocolError(At(n ? n : node_) + "field '" + key + "': " + what);
  }
  // "SOURCE:LINE: WHERE: " for a node of this map.
  std::string At(const YAML::Node& n) const {
    const int line = n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line : fallback_line_;
    return source_ + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": " + where_ +
           (where_.empty() ? "" : ": ");
  }
  bool Has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  YAML::Node Get(const std::string& key) {
    used_.insert(key);
    return node_[key];
  }
  std::string Scalar(const std::string& key) {
    YAML::Node n = Get(key);
    if (!n.IsScalar()) Fail(key, "expected a single value");
    return n.Scalar();
  }
  template <typename T>
  T Value(const std::string& key, T def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    YAML::Node n = Get(key);
    std::string why;
    const std::optional<T> v = Convert<T>(n, &why);
    if (!v) Fail(key, why);
    return *v;
  }
  // A scalar as T: ints and doubles strictly (io/strict_number.h: no hex, nan, inf, overflow).
  template <typename T>
  static std::optional<T> Convert(const YAML::Node& n, std::string* why) {
    if (!n.IsScalar()) {
      *why = "expected a single value, not a list or map";
      return std::nullopt;
    }
    if constexpr (std::is_same_v<T, int>) {
      int v = 0;
      *why = io::CheckInt(n.Scalar(), -kMaxPlanInt, kMaxPlanInt, &v);
      if (!why->empty()) return std::nullopt;
      return v;
    } else if constexpr (std::is_same_v<T, double>) {
      double v = 0;
      *why = io::CheckNumber(n.Scalar(), -1e9, 1e9, &v);
      if (!why->empty()) return std::nullopt;
      return v;
    } else {
      try {
        return n.as<T>();
      } catch (const YAML::Exception&) {
        *why = "'" + io::Printable(n.Scalar()) + "' has the wrong type";
        return std::nullopt;
      }
    }
  }
  int PositiveInt(const std::string& key, int def, int min_value = 1) {
    const int v = Value<int>(key, def);
    if (v < min_value) Fail(key, std::to_string(v) + " must be >= " + std::to_string(min_value));
    return v;
  }
  // A pulse-width quantity [us]: min_value .. kMaxPulseUs.
  int PulseUs(const std::string& key, int def, int min_value = 1) {
    const int v = PositiveInt(key, def, min_value);
    if (v > kMaxPulseUs) Fail(key, std::to_string(v) + " us is more than " + std::to_string(kMaxPulseUs) + " us");
    return v;
  }
  // A list of pulse-width offsets [us], each within +-kMaxPulseUs.
  std::vector<int> PulseOffsets(const std::string& key, std::vector<int> def) {
    std::vector<int> v = List<int>(key, std::move(def));
    for (int x : v)
      if (x < -kMaxPulseUs || x > kMaxPulseUs)
        Fail(key, std::to_string(x) + " us is outside +-" + std::to_string(kMaxPulseUs) + " us");
    return v;
  }
  double PositiveDouble(const std::string& key, double def, bool allow_zero = false) {
    const double v = Value<double>(key, def);
    if (!(allow_zero ? v >= 0 : v > 0)) Fail(key, std::to_string(v) + (allow_zero ? " must be >= 0" : " must be > 0"));
    return v;
  }
  template <typename T>
  std::vector<T> List(const std::string& key, std::vector<T> def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    YAML::Node n = Get(key);
    if (!n.IsSequence() || n.size() == 0) Fail(key, "expected a non-empty list");
    std::vector<T> out;
    if (n.size() > static_cast<size_t>(kMaxPlanSteps))
      Fail(key, "more than " + std::to_string(kMaxPlanSteps) + " entries");
    for (size_t i = 0; i < n.size(); ++i) {
      std::string why;
      const std::optional<T> v = Convert<T>(n[i], &why);
      if (!v) Fail(key, "entry " + std::to_string(i) + " " + why);
      out.push_back(*v);
    }
    return out;
  }
  PwmExpr Pwm(const std::string& key, PwmExpr def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    const std::string s = Scalar(key);
    auto e = ParsePwmExpr(s);
    if (!e) Fail(key, "'" + s + "' is not a pulse width (e.g. 1545, centre, centre+40, min+10, max-10)");
    return *e;
  }
  int Servo(const std::string& key) {
    const std::string s = Scalar(key);
    const int i = ServoIndexFromName(s);
    if (i < 0) Fail(key, "'" + s + "' is not a servo (Rx, Ry, Lx, Ly, Neck)");
    return i;
  }
  void RejectUnknown() const {
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (!used_.count(k)) throw ProtocolError(At(kv.first) + "unknown field '" + k + "'");
    }
  }
  // An enum from one of its names.
  template <typename E>
  E Enum(const std::string& key, E def, std::initializer_list<std::pair<const char*, E>> names) {
    const char* def_name = "";
    for (const auto& [name, value] : names)
      if (value == def) def_name = name;
    const std::string v = Value<std::string>(key, def_name);
    std::string list;
    for (const auto& [name, value] : names) {
      if (v == name) return value;
      list += std::string(list.empty() ? "" : ", ") + name;
    }
    Fail(key, "'" + v + "' is not one of " + list);
  }

 private:
  YAML::Node node_;
  std::string source_, where_;
  int fallback_line_ = -1;
  std::set<std::string> used_;
};

// The fields of one step of kind `kind` (`where` names it in errors); throws ProtocolError for an
// unknown kind.
StepParams ParseStepParams(const std::string& kind, Fields& f, const std::string& source, const std::string& where);

}  // namespace owlcal::protocols::internal
