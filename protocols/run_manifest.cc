#include "protocols/run_manifest.h"

#include <exception>

#include "owlcal_version.h"

namespace owlcal::protocols {

nlohmann::json NewRunManifest(const std::vector<Protocol>& protocols,
                              robot::RobotInterface& robot,
                              const RunOptions& options) {
  const models::RobotConfig& config = robot.Config();
  nlohmann::json m;
  m["owlcal_version"] = OWLCAL_VERSION;
  m["robot"] = {{"spec", options.robot_spec},
                {"description", robot.Describe()},
                {"robot_file", options.robot_file},
                {"robot_file_text", options.robot_file_text}};
  nlohmann::json servos = nlohmann::json::array();
  for (const models::ServoConfig& s : config.servos)
    servos.push_back({{"name", s.name},
                      {"min_us", s.min_us},
                      {"max_us", s.max_us},
                      {"centre_us", s.centre_us},
                      {"direction", s.direction},
                      {"nominal_deg_per_us", s.nominal_deg_per_us}});
  m["robot"]["config"] = {{"name", config.name},
                          {"servos", servos},
                          {"ipd_m", config.ipd_m},
                          {"image_width", config.image_width},
                          {"image_height", config.image_height},
                          {"swap_eyes", config.swap_eyes},
                          {"mirror_stream", config.mirror_stream}};
  m["protocols"] = nlohmann::json::array();
  for (const Protocol& p : protocols)
    m["protocols"].push_back({{"file", p.file}, {"name", p.name}, {"target", p.target}, {"text", p.text}});
  nlohmann::json steps = nlohmann::json::array();
  size_t i = 0;
  for (const Protocol& p : protocols)
    for (const Step& s : p.steps)
      steps.push_back({{"step_index", i++}, {"name", s.name}, {"kind", StepKindName(s.kind())}, {"protocol", p.name}});
  m["num_steps"] = i;
  m["steps"] = steps;
  if (!options.sim.is_null()) {
    m["sim"] = options.sim;
    if (robot::SceneControl* sc = robot.Scene()) {
      try {
        m["sim"]["truth_json"] = nlohmann::json::parse(sc->TruthJson());
      } catch (const std::exception&) {
        m["sim"]["truth_text"] = sc->TruthJson();
      }
    }
  }
  return m;
}

bool RecordedWithProtocols(const nlohmann::json& manifest, const std::vector<Protocol>& protocols) {
  const auto& recorded = manifest.value("protocols", nlohmann::json::array());
  bool same = recorded.size() == protocols.size();
  for (size_t i = 0; same && i < protocols.size(); ++i) same = recorded[i].value("text", "") == protocols[i].text;
  return same;
}

}  // namespace owlcal::protocols
