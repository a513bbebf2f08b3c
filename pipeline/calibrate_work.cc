#include "pipeline/calibrate_work.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <stdexcept>

#include "pipeline/calibrate_pipeline.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {

// The robot clock of a dataset's first step (datasets without steps sort last).
int64_t FirstStepNs(const std::string& dataset) {
  const std::vector<protocols::StepRecord> steps = protocols::ReadStepsCsv(dataset);
  int64_t first = std::numeric_limits<int64_t>::max();
  for (const protocols::StepRecord& s : steps) first = std::min(first, s.start_ns);
  return first;
}

}  // namespace

bool RunsAfterFit(const protocols::Protocol& p) {
  return std::any_of(p.steps.begin(), p.steps.end(), [](const protocols::Step& st) {
    return st.kind() == protocols::StepKind::kSaccade;
  });
}

std::vector<const protocols::Protocol*> CalibrateOrder(const std::vector<protocols::Protocol>& loaded) {
  std::vector<const protocols::Protocol*> out;
  for (const protocols::Protocol& p : loaded)
    if (!RunsAfterFit(p)) out.push_back(&p);
  for (const protocols::Protocol& p : loaded)
    if (RunsAfterFit(p)) out.push_back(&p);
  return out;
}

std::vector<protocols::ProtocolWork> PlanCalibrateWork(const std::vector<protocols::Protocol>& loaded,
                                                       const models::RobotConfig& config) {
  protocols::SceneState scene;
  std::vector<protocols::ProtocolWork> out;
  for (const protocols::Protocol* p : CalibrateOrder(loaded)) out.push_back(protocols::PlanWork(*p, config, &scene));
  return out;
}

nlohmann::json CalibrateWorkJson(const std::map<std::string, std::string>& datasets,
                                 std::vector<protocols::ProtocolWork>* counted_out) {
  // A dataset that cannot be counted (no protocol text, unreadable tables) is a row with its
  // reason, never a failed run.
  nlohmann::json not_counted = nlohmann::json::array();
  std::vector<std::pair<int64_t, std::string>> order;
  for (const auto& [name, dir] : datasets) {
    try {
      order.emplace_back(FirstStepNs(dir), dir);
    } catch (const std::exception& e) {
      not_counted.push_back({{"dataset", dir}, {"status", "not counted"}, {"reason", e.what()}});
    }
  }
  std::sort(order.begin(), order.end());
  protocols::SceneState planned_scene, counted_scene;
  std::vector<protocols::ProtocolWork> planned, counted;
  for (const auto& [first_ns, dir] : order) {
    try {
      const nlohmann::json m = protocols::ReadManifest(dir);
      const models::RobotConfig config = RobotConfigFromManifest(m, dir + "/manifest.json");
      std::vector<protocols::ProtocolWork> parts;
      std::string name;
      for (const auto& entry : m.value("protocols", nlohmann::json::array())) {
        if (!entry.contains("text") || !entry["text"].is_string()) continue;
        parts.push_back(
            protocols::PlanWork(protocols::ParseProtocolYaml(entry["text"].get<std::string>(), dir + "/manifest.json"),
                                config,
                                &planned_scene));
        name += (name.empty() ? "" : "+") + parts.back().protocol;
      }
      const protocols::ProtocolWork done = protocols::CountWork(dir, &counted_scene);
      protocols::ProtocolWork plan = protocols::TotalWork(parts);
      plan.protocol = name;
      planned.push_back(plan);
      counted.push_back(done);
    } catch (const std::exception& e) {
      not_counted.push_back({{"dataset", dir}, {"status", "not counted"}, {"reason", e.what()}});
    }
  }
  nlohmann::json j = {{"planned", nlohmann::json::array()},
                      {"counted", nlohmann::json::array()},
                      {"planned_total", protocols::WorkJson(protocols::TotalWork(planned))},
                      {"counted_total", protocols::WorkJson(protocols::TotalWork(counted))},
                      {"note",
                       "placements: place-target steps that change the scene (a target left where it is "
                       "counts once); robot time: every step but place-target, counted from steps.csv; "
                       "planned: the open-loop steps only (closed-loop steps take the time the images "
                       "decide)"}};
  for (const auto& w : planned) j["planned"].push_back(protocols::WorkJson(w));
  for (const auto& w : counted) j["counted"].push_back(protocols::WorkJson(w));
  j["not_counted"] = not_counted;
  if (counted_out) *counted_out = counted;
  return j;
}

}  // namespace owlcal::pipeline
