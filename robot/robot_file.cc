#include "robot/robot_file.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.h"
#include "io/yaml_fields.h"

namespace owlcal::robot {
namespace {

[[noreturn]] void Fail(const std::string& source, const std::string& message) {
  throw std::runtime_error(source + ": " + message);
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
    for (auto [name, v] :
         {std::pair<const char*, int>{"min_us", s.min_us}, {"max_us", s.max_us}, {"centre_us", s.centre_us}}) {
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
  if (config.image_width < kMinImageSide || config.image_width > kMaxImageSide) {
    return "image.width = " + std::to_string(config.image_width) + " is not in " + std::to_string(kMinImageSide) +
           ".." + std::to_string(kMaxImageSide) + " px";
  }
  if (config.image_height < kMinImageSide || config.image_height > kMaxImageSide) {
    return "image.height = " + std::to_string(config.image_height) + " is not in " + std::to_string(kMinImageSide) +
           ".." + std::to_string(kMaxImageSide) + " px";
  }
  return "";
}

models::RobotConfig RobotConfigFromYaml(const YAML::Node& root, const std::string& source) {
  if (!root || root.IsNull()) Fail(source, "the file is empty");
  io::YamlFields f(root, source);
  f.ExpectOnly({"name", "ipd_mm", "image", "servos"});
  models::RobotConfig config;
  // Integers are read over a wide range here; ValidateRobotConfig says what is wrong with them.
  constexpr int kWide = 1000000;
  config.name = f.String("name", std::filesystem::path(source).stem().string());
  config.ipd_m = f.Number("ipd_mm", config.ipd_m * 1000, -1e6, 1e6) / 1000.0;
  if (auto image = f.OptionalMap("image")) {
    config.image_width = image->Int("width", config.image_width, -kWide, kWide);
    config.image_height = image->Int("height", config.image_height, -kWide, kWide);
    config.swap_eyes = image->Bool("swap_eyes", config.swap_eyes);
    config.mirror_stream = image->Bool("mirror", config.mirror_stream);
    image->RejectUnknown();
  }
  if (!f.Has("servos")) Fail(source, "missing field servos (Rx, Ry, Lx, Ly, Neck)");
  io::YamlFields servos = f.Map("servos");
  servos.ExpectOnly({"Rx", "Ry", "Lx", "Ly", "Neck"});
  for (int i = 0; i < models::kNumServos; ++i) {
    const std::string name = models::kServoNames[i];
    if (!servos.Has(name)) Fail(source, "missing field servos." + name);
    io::YamlFields s = servos.Map(name);
    models::ServoConfig& c = config.servos[i];
    c.name = name;
    c.min_us = s.Int("min_us", -kWide, kWide);
    c.max_us = s.Int("max_us", -kWide, kWide);
    c.centre_us = s.Int("centre_us", -kWide, kWide);
    c.direction = s.Int("direction", -kWide, kWide);
    c.nominal_deg_per_us = s.Number("deg_per_us", 0.113, -1e6, 1e6);
    s.RejectUnknown();
  }
  servos.RejectUnknown();
  f.RejectUnknown();
  const std::string why = ValidateRobotConfig(config);
  if (!why.empty()) Fail(source, why);
  return config;
}

models::RobotConfig LoadRobotFile(const std::string& path) {
  return RobotConfigFromYaml(io::LoadYamlFile(path, "robot file"), path);
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
  io::WriteFileAtomic(path, RobotConfigToYaml(config));
}

}  // namespace owlcal::robot
