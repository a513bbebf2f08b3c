#include "fitting/robot_config_json.h"

#include <stdexcept>
#include <string>

namespace owlcal::fitting {

using json = nlohmann::json;

json RobotConfigToJson(const models::RobotConfig& c) {
  json s = json::array();
  for (const auto& v : c.servos)
    s.push_back({{"name", v.name},
                 {"min_us", v.min_us},
                 {"max_us", v.max_us},
                 {"centre_us", v.centre_us},
                 {"direction", v.direction},
                 {"nominal_deg_per_us", v.nominal_deg_per_us}});
  return {{"name", c.name},
          {"servos", s},
          {"ipd_m", c.ipd_m},
          {"image_width", c.image_width},
          {"image_height", c.image_height},
          {"swap_eyes", c.swap_eyes},
          {"mirror_stream", c.mirror_stream}};
}

models::RobotConfig RobotConfigFromJson(const json& j) {
  models::RobotConfig c;
  c.name = j.value("name", c.name);
  if (j.contains("servos")) {
    if (j.at("servos").size() != models::kNumServos) throw std::runtime_error("robot.servos must have 5 entries");
    for (int i = 0; i < models::kNumServos; ++i) {
      const json& s = j.at("servos")[i];
      c.servos[i].name = s.value("name", std::string(models::kServoNames[i]));
      c.servos[i].min_us = s.at("min_us").get<int>();
      c.servos[i].max_us = s.at("max_us").get<int>();
      c.servos[i].centre_us = s.at("centre_us").get<int>();
      c.servos[i].direction = s.value("direction", 1);
      c.servos[i].nominal_deg_per_us = s.value("nominal_deg_per_us", 0.113);
    }
  }
  c.ipd_m = j.value("ipd_m", c.ipd_m);
  c.image_width = j.value("image_width", c.image_width);
  c.image_height = j.value("image_height", c.image_height);
  c.swap_eyes = j.value("swap_eyes", false);
  c.mirror_stream = j.value("mirror_stream", false);
  return c;
}

}  // namespace owlcal::fitting
