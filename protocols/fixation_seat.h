#pragma once
// The seating step of the fixation loop (protocols/fixation.h, "Seating").
#include <array>

#include "models/robot_config.h"
#include "protocols/fixation.h"

namespace owlcal::protocols {

// Seats a converged command (FixationOptions seat_*, protocols/fixation.h): snaps each controlled
// servo to the seating grid, reaches it with one move of seat_back_us from a known side, waits,
// and measures the residual offsets there. r->outcome becomes kLost when the target is not
// found in a controlled eye at the end.
void SeatCommand(const FixationOptions& o,
                 const models::RobotConfig& robot,
                 TargetLocator& locator,
                 const FixationIo& io,
                 const std::array<int, models::kNumServos>& approach,
                 FixationResult* r);

}  // namespace owlcal::protocols
