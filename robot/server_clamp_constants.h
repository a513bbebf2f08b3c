#pragma once
// The Pi server's clamp table of one robot, in the two forms of the Owl user guide
// (shared/seeds course notes):
//   - the Python server (code snippet 4): "if (Ry>2000):\n    Ry = 2000" for the top and bottom
//     of Ry, Rx, Ly, Lx and Neck, to paste into the server's packet loop after the fields are read;
//   - the C/C++ host (code snippet 5, owl-pwm.h): "int RyB = 1120; // (bottom) to" ... the names
//     RyB RyT RxR RxL LyB LyT LxR LxL NeckR NeckL, the centres RxC RyC LxC LyC NeckC and the
//     *Range values.
// The guide names ends by where the eye or head points: R/L the robot's right/left (pan, neck),
// T/B top/bottom (tilt); which of min_us/max_us that is follows each servo's direction
// (models/robot_config.h), e.g. the guide's Ly is mirrored (LyB = 2000, LyT = 1180) and its neck
// turns left with increasing PWM (NeckR = 1100, NeckL = 1950).
#include <string>

#include "models/robot_config.h"

namespace owlcal::robot {

// The pulse width at the end of `servo` where the joint angle is positive (right / up) or not.
int ServoEndUs(const models::RobotConfig& config, int servo, bool positive_angle);

// Python (snippet 4 form), with a header comment naming the robot.
std::string PythonServerClamp(const models::RobotConfig& config);

// C and C++ (snippet 5 form), with a header comment naming the robot.
std::string CServerRanges(const models::RobotConfig& config);

}  // namespace owlcal::robot
