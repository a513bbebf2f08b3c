#pragma once
// Strict reading of YAML files, shared by every YAML reader (robot file, robot truth, protocols,
// targets, scenes). yaml-cpp alone accepts a key given twice (the first silently wins), a list
// where a key belongs ("bad conversion", no file named), ".nan", ".inf" and hex numbers; these
// helpers refuse each, naming the file, the line and the dotted field, e.g.
//   "robots/x.yaml:7: servos.Rx.min_us = '0x4b0' is not an integer"
//   "robots/x.yaml:9: key 'servos.Rx' given twice (first on line 5)"
//   "truth.yaml:3: unknown field 'stream.fsp' (expected one of: blur_px, eye_offset_ms, ...)"
// Lines are 1-based. Numbers follow io/strict_number.h and each read gives its allowed range.
//
// Usage:
//   const YAML::Node root = io::LoadYamlFile(path, "robot file");
//   io::YamlFields f(root, path);
//   const double ipd_mm = f.Number("ipd_mm", 65.0, 1, 1000);   // optional, default 65
//   io::YamlFields image = f.Map("image");                      // required map
//   const int width = image.Int("width", 1, 16384);             // required
//   image.RejectUnknown();
//   f.RejectUnknown();
// Errors throw std::runtime_error.
#include <cstdint>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

namespace owlcal::io {

// Parses YAML text; a syntax error throws "SOURCE:LINE:COL: not valid YAML: why"; an empty
// document (nothing but comments) throws "SOURCE: the file is empty". Only the first document
// of a multi-document stream is read; a second one is an error.
YAML::Node LoadYamlText(const std::string& text, const std::string& source);
// Reads and parses a file; "PATH: cannot open WHAT" if it cannot be read.
YAML::Node LoadYamlFile(const std::string& path, const std::string& what = "file");

// The fields of one YAML mapping. Construction refuses a node that is not a map, a key that is
// not a plain scalar, and a key given twice. Each getter marks its key as read, so
// RejectUnknown() can name any key no reader asked for.
class YamlFields {
 public:
  // `source` names the file in errors; `path` is the dotted field path of this map ("" = root).
  YamlFields(const YAML::Node& node, std::string source, std::string path = "");

  bool Has(const std::string& key) const { return entries_.count(key) > 0; }
  // The raw node (marks the key read); an invalid (undefined) node if absent.
  YAML::Node Get(const std::string& key);

  // Nested maps: required, or nullopt when absent.
  YamlFields Map(const std::string& key);
  std::optional<YamlFields> OptionalMap(const std::string& key);

  // Scalars: required (Fail "missing field" if absent) or with a default. A list or map where a
  // scalar belongs is an error naming the field.
  std::string String(const std::string& key);
  std::string String(const std::string& key, const std::string& def);
  double Number(const std::string& key, double min, double max);
  double Number(const std::string& key, double def, double min, double max);
  int Int(const std::string& key, int min, int max);
  int Int(const std::string& key, int def, int min, int max);
  bool Bool(const std::string& key);
  bool Bool(const std::string& key, bool def);
  // A flow or block list of numbers; count 0 = any non-empty length.
  std::vector<double> Numbers(const std::string& key, size_t count, double min, double max);

  // Throws "SOURCE:LINE: unknown field 'PATH.key' (expected one of: ...)" for the first key never read.
  void RejectUnknown() const;
  // The same, before reading, for the first key not in `allowed` (so a misspelt key is named
  // rather than the key it was meant to be reported missing).
  void ExpectOnly(std::initializer_list<const char*> allowed) const;
  // Keys in file order.
  const std::vector<std::string>& Keys() const { return keys_; }

  // "SOURCE:LINE: PATH.key WHAT" (line of the key, or of this map when the key is absent).
  [[noreturn]] void Fail(const std::string& key, const std::string& what) const;
  std::string FieldName(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  const std::string& Source() const { return source_; }
  const std::string& Path() const { return path_; }

 private:
  struct Entry {
    YAML::Node value;
    int line = 0;  // 1-based line of the key
  };
  const Entry& Scalar(const std::string& key);
  std::string Where(const std::string& key) const;

  std::string source_, path_;
  int line_ = 0;  // of the map itself
  std::map<std::string, Entry> entries_;
  std::vector<std::string> keys_;
  std::set<std::string> read_;
};

}  // namespace owlcal::io
