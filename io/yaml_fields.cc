#include "io/yaml_fields.h"

#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/eventhandler.h>

#include "io/strict_number.h"

namespace owlcal::io {
namespace {

[[noreturn]] void Throw(const std::string& what) { throw std::runtime_error(what); }

// "SOURCE:LINE", or "SOURCE" when the line is unknown (0).
std::string At(const std::string& source, int line) {
  std::string out = source;
  if (line > 0) {
    out += ':';
    out += std::to_string(line);
  }
  return out;
}

// Counts documents and remembers where each starts; builds nothing.
class DocumentMarks : public YAML::EventHandler {
 public:
  std::vector<YAML::Mark> starts;
  void OnDocumentStart(const YAML::Mark& mark) override { starts.push_back(mark); }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark&, YAML::anchor_t) override {}
  void OnScalar(const YAML::Mark&, const std::string&, YAML::anchor_t, const std::string&) override {}
  void OnSequenceStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark&, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {}
  void OnMapEnd() override {}
};

int LineOf(const YAML::Node& n) {
  if (!n.IsDefined()) return 0;
  const YAML::Mark m = n.Mark();
  return m.is_null() ? 0 : m.line + 1;
}

}  // namespace

YAML::Node LoadYamlText(const std::string& text, const std::string& source) {
  // Not YAML::LoadAll: yaml-cpp 0.7 yields an empty document for a stray top-level ',' forever
  // without consuming it (found by fuzz/robot_truth_fuzz: LoadAll(",") never returns). Count at
  // most two documents with the event parser, and call a document that starts where the previous
  // one started what it is: no progress.
  YAML::Node root;
  try {
    std::istringstream in(text);
    YAML::Parser parser(in);
    DocumentMarks marks;
    while (marks.starts.size() < 2 && parser.HandleNextDocument(marks)) {
    }
    if (marks.starts.size() == 2) {
      const YAML::Mark& second = marks.starts[1];
      if (second.pos == marks.starts[0].pos) {
        const char c = second.pos >= 0 && static_cast<size_t>(second.pos) < text.size() ? text[second.pos] : '?';
        Throw(source + ":" + std::to_string(second.line + 1) + ":" + std::to_string(second.column + 1) +
              ": not valid YAML: unexpected '" + Printable(std::string(1, c)) + "'");
      }
      Throw(At(source, second.line + 1) + ": a second YAML document ('---') is not allowed");
    }
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    // yaml-cpp's own message repeats the position; keep only its reason.
    Throw(source + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
          ": not valid YAML: " + e.msg);
  }
  if (!root.IsDefined() || root.IsNull()) Throw(source + ": the file is empty");
  return root;
}

YAML::Node LoadYamlFile(const std::string& path, const std::string& what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Throw(path + ": cannot open " + what);
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) Throw(path + ": read error");
  return LoadYamlText(s.str(), path);
}

YamlFields::YamlFields(const YAML::Node& node, std::string source, std::string path)
    : source_(std::move(source)), path_(std::move(path)), line_(LineOf(node)) {
  const std::string name = path_.empty() ? "the file" : "'" + path_ + "'";
  if (!node.IsDefined() || !node.IsMap()) {
    Throw(At(source_, line_) + ": " + name + " must be a map of key: value");
  }
  for (const auto& kv : node) {
    const int line = LineOf(kv.first);
    const std::string at = At(source_, line) + ": ";
    if (!kv.first.IsScalar())
      Throw(at + "a key of " + name + " is a " + (kv.first.IsSequence() ? "list" : "map") + ", not a name");
    const std::string key = kv.first.Scalar();
    const auto it = entries_.find(key);
    if (it != entries_.end()) {
      Throw(at + "key '" + Printable(FieldName(key)) + "' given twice (first on line " +
            std::to_string(it->second.line) + ")");
    }
    entries_[key] = {kv.second, line};
    keys_.push_back(key);
  }
}

std::string YamlFields::Where(const std::string& key) const {
  const auto it = entries_.find(key);
  const int line = it != entries_.end() ? it->second.line : line_;
  return At(source_, line);
}

void YamlFields::Fail(const std::string& key, const std::string& what) const {
  Throw(Where(key) + ": " + Printable(FieldName(key)) + " " + what);
}

YAML::Node YamlFields::Get(const std::string& key) {
  read_.insert(key);
  const auto it = entries_.find(key);
  return it == entries_.end() ? YAML::Node(YAML::NodeType::Undefined) : it->second.value;
}

YamlFields YamlFields::Map(const std::string& key) {
  if (!Has(key)) Throw(Where(key) + ": missing field " + FieldName(key));
  read_.insert(key);
  const Entry& e = entries_.at(key);
  if (!e.value.IsMap()) Fail(key, "must be a map of key: value");
  return YamlFields(e.value, source_, FieldName(key));
}

std::optional<YamlFields> YamlFields::OptionalMap(const std::string& key) {
  if (!Has(key)) {
    read_.insert(key);
    return std::nullopt;
  }
  return Map(key);
}

const YamlFields::Entry& YamlFields::Scalar(const std::string& key) {
  if (!Has(key)) Throw(Where(key) + ": missing field " + FieldName(key));
  read_.insert(key);
  const Entry& e = entries_.at(key);
  if (!e.value.IsScalar()) {
    Fail(key,
         std::string("must be a single value, not a ") + (e.value.IsSequence() ? "list"
                                                          : e.value.IsMap()    ? "map"
                                                                               : "null"));
  }
  return e;
}

std::string YamlFields::String(const std::string& key) { return Scalar(key).value.Scalar(); }

std::string YamlFields::String(const std::string& key, const std::string& def) {
  if (!Has(key)) {
    read_.insert(key);
    return def;
  }
  return String(key);
}

double YamlFields::Number(const std::string& key, double min, double max) {
  double v = 0;
  const std::string why = CheckNumber(Scalar(key).value.Scalar(), min, max, &v);
  if (!why.empty()) Fail(key, why);
  return v;
}

double YamlFields::Number(const std::string& key, double def, double min, double max) {
  if (!Has(key)) {
    read_.insert(key);
    return def;
  }
  return Number(key, min, max);
}

int YamlFields::Int(const std::string& key, int min, int max) {
  int v = 0;
  const std::string why = CheckInt(Scalar(key).value.Scalar(), min, max, &v);
  if (!why.empty()) Fail(key, why);
  return v;
}

int YamlFields::Int(const std::string& key, int def, int min, int max) {
  if (!Has(key)) {
    read_.insert(key);
    return def;
  }
  return Int(key, min, max);
}

bool YamlFields::Bool(const std::string& key) {
  const Entry& e = Scalar(key);
  bool b = false;
  if (!YAML::convert<bool>::decode(e.value, b))
    Fail(key, "= '" + Printable(e.value.Scalar()) + "' is not true or false");
  return b;
}

bool YamlFields::Bool(const std::string& key, bool def) {
  if (!Has(key)) {
    read_.insert(key);
    return def;
  }
  return Bool(key);
}

std::vector<double> YamlFields::Numbers(const std::string& key, size_t count, double min, double max) {
  if (!Has(key)) Throw(Where(key) + ": missing field " + FieldName(key));
  read_.insert(key);
  const YAML::Node n = entries_.at(key).value;
  if (!n.IsSequence() || n.size() == 0) Fail(key, "must be a non-empty list of numbers");
  if (count != 0 && n.size() != count)
    Fail(key, "has " + std::to_string(n.size()) + " values, expected " + std::to_string(count));
  std::vector<double> out;
  for (size_t i = 0; i < n.size(); ++i) {
    std::string item = "[";
    item += std::to_string(i);
    item += ']';
    if (!n[i].IsScalar()) Fail(key, item + " must be a number, not a " + (n[i].IsSequence() ? "list" : "map"));
    double v = 0;
    const std::string why = CheckNumber(n[i].Scalar(), min, max, &v);
    if (!why.empty()) Fail(key, item + " " + why);
    out.push_back(v);
  }
  return out;
}

void YamlFields::ExpectOnly(std::initializer_list<const char*> allowed) const {
  for (const std::string& key : keys_) {
    bool ok = false;
    for (const char* a : allowed) ok = ok || key == a;
    if (ok) continue;
    std::string list;
    for (const char* a : allowed) {
      if (!list.empty()) list += ", ";
      list += a;
    }
    Throw(Where(key) + ": unknown field '" + Printable(FieldName(key)) + "' (expected one of: " + list + ")");
  }
}

void YamlFields::RejectUnknown() const {
  for (const std::string& key : keys_) {
    if (read_.count(key)) continue;
    std::string list;
    for (const std::string& k : read_) {
      if (!list.empty()) list += ", ";
      list += k;
    }
    Throw(Where(key) + ": unknown field '" + Printable(FieldName(key)) + "' (expected one of: " + list + ")");
  }
}

}  // namespace owlcal::io
