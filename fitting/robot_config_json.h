#pragma once
// A robot configuration (models/robot_config.h) as JSON: {"name", "servos": [{"name", "min_us",
// "max_us", "centre_us", "direction", "nominal_deg_per_us"} x 5 in wire order], "ipd_m",
// "image_width", "image_height", "swap_eyes", "mirror_stream"}. The same object is a dataset
// manifest's robot.config (protocols/run_manifest.cc) and evaluation.json's robot.
#include <nlohmann/json.hpp>

#include "models/robot_config.h"

namespace owlcal::fitting {

nlohmann::json RobotConfigToJson(const models::RobotConfig& c);
// Missing fields keep RobotConfig's defaults; a malformed one throws (nlohmann::json or
// std::runtime_error).
models::RobotConfig RobotConfigFromJson(const nlohmann::json& j);

}  // namespace owlcal::fitting
