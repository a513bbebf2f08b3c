#pragma once
// The checks made before a run moves anything. PlanRun (the dry-run plan) is declared in
// protocols/runner.h.
#include <vector>

#include "models/robot_config.h"
#include "protocols/protocol.h"

namespace owlcal::protocols {

// Throws ProtocolError for the first step whose pulse widths do not fit the robot file.
void CheckProtocolsForRobot(const std::vector<Protocol>& protocols, const models::RobotConfig& robot);

}  // namespace owlcal::protocols
