// person_work: the target placements and the robot's time per protocol, planned and counted from
// the datasets (results.json diagnostics.person_work, pipeline/calibrate_work.h).
#include <string>
#include <vector>

#include "reports/report_tables.h"

namespace owlcal::reports::internal {

void AppendPersonWorkTable(const ReportData& d, std::vector<Table>* out) {
  const nlohmann::json& diag = d.result.diagnostics;
  if (!diag.contains("person_work") || !diag["person_work"].contains("counted")) return;
  const nlohmann::json& pw = diag["person_work"];
  Table t{
      "person_work",
      "The person's work and the robot's time per protocol, in the order recorded: " + pw.value("note", std::string()),
      {"protocol",
       "placements",
       "planned placements",
       "place-target steps",
       "robot time [s]",
       "of it closed-loop [s]",
       "planned open-loop [s]",
       "closed-loop steps",
       "steps not done"},
      {}};
  const nlohmann::json planned = pw.value("planned", nlohmann::json::array());
  auto row = [&](const nlohmann::json& c, const nlohmann::json& p) {
    t.rows.push_back({c.value("protocol", std::string()),
                      std::to_string(c.value("placements", 0)),
                      p.is_object() ? std::to_string(p.value("placements", 0)) : "",
                      std::to_string(c.value("placement_steps", 0)),
                      Fmt(c.value("robot_time_s", 0.0), 4),
                      Fmt(c.value("closed_loop_s", 0.0), 4),
                      p.is_object() ? Fmt(p.value("robot_time_s", 0.0), 4) : "",
                      std::to_string(c.value("closed_loop_steps", 0)),
                      std::to_string(c.value("steps_not_done", 0))});
  };
  const nlohmann::json& counted = pw["counted"];
  for (size_t i = 0; i < counted.size(); ++i) row(counted[i], i < planned.size() ? planned[i] : nlohmann::json());
  for (const auto& n : pw.value("not_counted", nlohmann::json::array()))
    t.rows.push_back({n.value("dataset", std::string()),
                      n.value("status", std::string()) + ": " + n.value("reason", std::string()),
                      "",
                      "",
                      "",
                      "",
                      "",
                      "",
                      ""});
  if (pw.contains("counted_total")) row(pw["counted_total"], pw.value("planned_total", nlohmann::json()));
  out->push_back(t);
}

}  // namespace owlcal::reports::internal
