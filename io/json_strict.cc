#include "io/json_strict.h"

#include <cmath>

#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "io/strict_number.h"

namespace owlcal::io {

nlohmann::json ParseJsonStrict(const std::string& text, const std::string& source) {
  using json = nlohmann::json;
  // One set of keys per open object, and the dotted path of the objects we are inside.
  struct Level {
    std::set<std::string> keys;
    std::string path;
  };
  std::vector<Level> levels;
  std::string last_key;
  json::parser_callback_t callback = [&](int /*depth*/, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start: {
        const std::string parent = levels.empty() ? "" : levels.back().path;
        const std::string path = levels.empty() ? "" : (parent.empty() ? last_key : parent + "." + last_key);
        levels.push_back({{}, path});
        break;
      }
      case json::parse_event_t::object_end:
        if (!levels.empty()) levels.pop_back();
        break;
      case json::parse_event_t::key: {
        last_key = parsed.get<std::string>();
        if (!levels.empty() && !levels.back().keys.insert(last_key).second) {
          const std::string& p = levels.back().path;
          throw std::runtime_error(source + ": key '" + Printable(p.empty() ? last_key : p + "." + last_key) +
                                   "' given twice");
        }
        break;
      }
      case json::parse_event_t::array_start:
        // Objects inside an array are named by the array's key.
        break;
      default:
        break;
    }
    return true;
  };
  try {
    return json::parse(text, callback);
  } catch (const json::exception& e) {  // parse_error, out_of_range (a number that overflows)
    throw std::runtime_error(source + ": not valid JSON: " + e.what());
  }
}

nlohmann::json ReadJsonFileStrict(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  return ParseJsonStrict(s.str(), path);
}

nlohmann::json JsonNumber(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
nlohmann::json JsonNumber(const std::optional<double>& v) { return v ? JsonNumber(*v) : nlohmann::json(nullptr); }

}  // namespace owlcal::io
