#pragma once
// The person's work and the robot's time of `owlcal calibrate` (protocols/person_work.h says how
// each is counted), per protocol in the order calibrate records them: planned from the protocol
// files before the run (`owlcal calibrate --dry-run`) and, after it, both planned and counted
// from the recorded datasets (results.json diagnostics.person_work, the report's summary).
//
// Usage:
//   const auto plan = pipeline::PlanCalibrateWork(loaded, robot.Config());   // before
//   run.result.diagnostics["person_work"] = pipeline::CalibrateWorkJson(datasets);  // after
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/robot_config.h"
#include "protocols/person_work.h"
#include "protocols/protocol.h"

namespace owlcal::pipeline {

// True for a protocol calibrate records after its fit (one with a saccade step: it needs the
// calibrated maps).
bool RunsAfterFit(const protocols::Protocol& protocol);

// The protocols in calibrate's recording order: as given, those that RunsAfterFit last.
std::vector<const protocols::Protocol*> CalibrateOrder(const std::vector<protocols::Protocol>& loaded);

// The planned work of each protocol, in CalibrateOrder, on the robot file's configuration (the
// protocols after `limits` run on the limits it measures, which may move their poses).
std::vector<protocols::ProtocolWork> PlanCalibrateWork(const std::vector<protocols::Protocol>& loaded,
                                                       const models::RobotConfig& config);

// diagnostics.person_work of a calibrate run's datasets (protocol name -> folder), in the order
// they were recorded (the robot clock of each one's first step): {"planned": [rows], "counted":
// [rows], "planned_total", "counted_total", "note"}, rows of protocols::WorkJson. "planned" is
// planned on each dataset's own recorded configuration and protocol texts. A dataset that cannot
// be read (no protocol text, an unreadable table) is a row of "not_counted" with the reason,
// {"dataset", "status": "not counted", "reason"}, and left out of the rest. *counted (when
// given): the counted rows.
nlohmann::json CalibrateWorkJson(const std::map<std::string, std::string>& datasets,
                                 std::vector<protocols::ProtocolWork>* counted = nullptr);

}  // namespace owlcal::pipeline
