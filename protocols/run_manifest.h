#pragma once
// The manifest a protocol run writes into a new dataset (manifest.json, protocols/dataset.h):
// owlcal version, robot (spec, description, robot file and its text, the configuration), the
// protocols with their text, the flattened steps and, for the virtual Owl, its seed and truth.
#include <vector>

#include <nlohmann/json.hpp>

#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

nlohmann::json NewRunManifest(const std::vector<Protocol>& protocols,
                              robot::RobotInterface& robot,
                              const RunOptions& options);

// True when the dataset's manifest was recorded with exactly these protocol files (by text):
// the condition for resuming it.
bool RecordedWithProtocols(const nlohmann::json& manifest, const std::vector<Protocol>& protocols);

}  // namespace owlcal::protocols
