#include "robot/robot_file.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>

namespace owlcal::robot {
namespace {

[[noreturn]] void Fail(const std::string& source, const std::string& message) {
  throw std::runtime_error(source + ": " + message);
}

std::string Scalar(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : std::string("(not a scalar)"); }

void CheckKeys(const YAML::Node& map, const std::set<std::string>& allowed, const std::string& source,
               const std::string& where) {
  if (!map.IsMap()) Fail(source, (where.empty() ? "the file" : where) + " must be a map of key: value");
  for (const auto& kv : map) {
    const std::string key = kv.first.as<std::string>();
    if (!allowed.count(key)) {
      std::string list;
      for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
      Fail(source, "unknown field '" + (where.empty() ? key : where + "." + key) + "' (expected one of: " + list + ")");
    }
  }
}

int ReadInt(const YAML::Node& map, const std::string& key, const std::string& source, const std::string& where) {
  const YAML::Node n = map[key];
  if (!n) Fail(source, "missing field " + where + "." + key);
  const std::string text = Scalar(n);
  size_t used = 0;
  long value = 0;
  try {
    value = std::stol(text, &used);
  } catch (...) {
    used = 0;
  }
  if (used == 0 || used != text.size() || value < -1000000 || value > 1000000) {
    Fail(source, where + "." + key + " = '" + text + "' is not an integer");
  }
  return static_cast<int>(value);
}

double ReadDouble(const YAML::Node& n, const std::string& field, const std::string& source) {
  const std::string text = Scalar(n);
  size_t used = 0;
  double value = NAN;
  try {
    value = std::stod(text, &used);
  } catch (...) {
    used = 0;
  }
  if (used == 0 || used != text.size() || !std::isfinite(value)) {
    Fail(source, field + " = '" + text + "' is not a number");
  }
  return value;
}

bool ReadBool(const YAML::Node& n, const std::string& field, const std::string& source) {
  bool b = false;
  if (!n.IsScalar() || !YAML::convert<bool>::decode(n, b)) {
    Fail(source, field + " = '" + Scalar(n) + "' is not true or false");
  }
  return b;
}

std::string FormatDouble(double v) {
  std::ostringstream s;
  s.precision(10);
  s << v;
  return s.str();
}

}  // namespace

std::string ValidateRobotConfig(const models::RobotConfig& config) {
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& s = config.servos[i];
    const std::string f = std::string("servos.") + models::kServoNames[i] + ".";
    for (auto [name, v] : {std::pair<const char*, int>{"min_us", s.min_us}, {"max_us", s.max_us},
                           {"centre_us", s.centre_us}}) {
      if (v < 1000 || v > 9999) {
        return f + name + " = " + std::to_string(v) + " is not a four-digit pulse width (1000..9999 us)";
      }
    }
    if (s.min_us >= s.max_us) {
      return f + "min_us = " + std::to_string(s.min_us) + " is " + (s.min_us == s.max_us ? "equal to" : "above") +
             " max_us " + std::to_string(s.max_us);
    }
    if (s.centre_us <= s.min_us) {
      return f + "centre_us = " + std::to_string(s.centre_us) + " is not above min_us " + std::to_string(s.min_us);
    }
    if (s.centre_us >= s.max_us) {
      return f + "centre_us = " + std::to_string(s.centre_us) + " is not below max_us " + std::to_string(s.max_us);
    }
    if (s.direction != 1 && s.direction != -1) {
      return f + "direction = " + std::to_string(s.direction) + " is not 1 or -1";
    }
    if (!(s.nominal_deg_per_us > 0) || !std::isfinite(s.nominal_deg_per_us)) {
      return f + "deg_per_us = " + FormatDouble(s.nominal_deg_per_us) + " is not positive";
    }
  }
  if (!(config.ipd_m > 0) || !std::isfinite(config.ipd_m) || config.ipd_m > 1.0) {
    return "ipd_mm = " + FormatDouble(config.ipd_m * 1000) + " is not in (0, 1000] mm";
  }
  if (config.image_width <= 0) return "image.width = " + std::to_string(config.image_width) + " is not positive";
  if (config.image_height <= 0) return "image.height = " + std::to_string(config.image_height) + " is not positive";
  return "";
}

models::RobotConfig RobotConfigFromYaml(const YAML::Node& root, const std::string& source) {
  if (!root || root.IsNull()) Fail(source, "the file is empty");
  CheckKeys(root, {"name", "ipd_mm", "image", "servos"}, source, "");
  models::RobotConfig config;
  config.name = root["name"] ? Scalar(root["name"]) : std::filesystem::path(source).stem().string();
  if (root["ipd_mm"]) config.ipd_m = ReadDouble(root["ipd_mm"], "ipd_mm", source) / 1000.0;
  if (const YAML::Node image = root["image"]) {
    CheckKeys(image, {"width", "height", "swap_eyes", "mirror"}, source, "image");
    if (image["width"]) config.image_width = ReadInt(image, "width", source, "image");
    if (image["height"]) config.image_height = ReadInt(image, "height", source, "image");
    if (image["swap_eyes"]) config.swap_eyes = ReadBool(image["swap_eyes"], "image.swap_eyes", source);
    if (image["mirror"]) config.mirror_stream = ReadBool(image["mirror"], "image.mirror", source);
  }
  const YAML::Node servos = root["servos"];
  if (!servos) Fail(source, "missing field servos (Rx, Ry, Lx, Ly, Neck)");
  CheckKeys(servos, {"Rx", "Ry", "Lx", "Ly", "Neck"}, source, "servos");
  for (int i = 0; i < models::kNumServos; ++i) {
    const std::string where = std::string("servos.") + models::kServoNames[i];
    const YAML::Node s = servos[models::kServoNames[i]];
    if (!s) Fail(source, "missing field " + where);
    CheckKeys(s, {"min_us", "max_us", "centre_us", "direction", "deg_per_us"}, source, where);
    models::ServoConfig& c = config.servos[i];
    c.name = models::kServoNames[i];
    c.min_us = ReadInt(s, "min_us", source, where);
    c.max_us = ReadInt(s, "max_us", source, where);
    c.centre_us = ReadInt(s, "centre_us", source, where);
    c.direction = ReadInt(s, "direction", source, where);
    c.nominal_deg_per_us =
        s["deg_per_us"] ? ReadDouble(s["deg_per_us"], where + ".deg_per_us", source) : 0.113;
  }
  const std::string why = ValidateRobotConfig(config);
  if (!why.empty()) Fail(source, why);
  return config;
}

models::RobotConfig LoadRobotFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot open robot file");
  YAML::Node root;
  try {
    root = YAML::Load(in);
  } catch (const YAML::Exception& e) {
    throw std::runtime_error(path + ": YAML error at line " + std::to_string(e.mark.line + 1) + ", column " +
                             std::to_string(e.mark.column + 1) + ": " + e.msg);
  }
  return RobotConfigFromYaml(root, path);
}

std::string RobotConfigToYaml(const models::RobotConfig& config) {
  std::ostringstream out;
  out << "# owlcal robot file: servo limits and centres in us (wire order Rx Ry Lx Ly Neck),\n"
      << "# direction = sign of the joint angle per increasing PWM (+1 right / up).\n";
  out << "name: " << YAML::Node(config.name) << "\n";
  out << "ipd_mm: " << FormatDouble(config.ipd_m * 1000) << "\n";
  out << "image: {width: " << config.image_width << ", height: " << config.image_height
      << ", swap_eyes: " << (config.swap_eyes ? "true" : "false")
      << ", mirror: " << (config.mirror_stream ? "true" : "false") << "}\n";
  out << "servos:\n";
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& s = config.servos[i];
    std::string key = std::string(models::kServoNames[i]) + ":";
    key.resize(6, ' ');
    out << "  " << key << " {min_us: " << s.min_us << ", max_us: " << s.max_us << ", centre_us: " << s.centre_us
        << ", direction: " << (s.direction > 0 ? " 1" : "-1") << ", deg_per_us: " << FormatDouble(s.nominal_deg_per_us)
        << "}\n";
  }
  return out.str();
}

void SaveRobotFile(const models::RobotConfig& config, const std::string& path) {
  const std::string why = ValidateRobotConfig(config);
  if (!why.empty()) throw std::runtime_error(path + ": not saved: " + why);
  std::ofstream out(path);
  out << RobotConfigToYaml(config);
  if (!out) throw std::runtime_error(path + ": cannot write robot file");
}

}  // namespace owlcal::robot
