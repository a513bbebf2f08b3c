#pragma once
// Strict JSON reading shared by every JSON reader (results.json, evaluation.json, manifests).
// nlohmann::json alone keeps the LAST of two equal keys in an object without a word; this
// refuses a key given twice, naming the file and the dotted key ("results.json: key
// 'cameras.left' given twice"). Syntax errors and numbers that overflow a double are
// nlohmann's parse errors, prefixed with the source.
//
// Usage:
//   const nlohmann::json j = io::ParseJsonStrict(text, path);
//   const nlohmann::json k = io::ReadJsonFileStrict(path);   // "PATH: cannot open" if unreadable
// Errors throw std::runtime_error.
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace owlcal::io {

nlohmann::json ParseJsonStrict(const std::string& text, const std::string& source);

// `v` as a JSON number, or null when it is not finite (JSON has no NaN or infinity: a value a
// trial did not give is written as null and read back as NaN).
nlohmann::json JsonNumber(double v);
nlohmann::json JsonNumber(const std::optional<double>& v);  // null when empty
nlohmann::json ReadJsonFileStrict(const std::string& path);

}  // namespace owlcal::io
