#include "robot/server_clamp_constants.h"

#include <sstream>

namespace owlcal::robot {

int ServoEndUs(const models::RobotConfig& config, int servo, bool positive_angle) {
  const models::ServoConfig& s = config.servos[servo];
  return (s.direction > 0) == positive_angle ? s.max_us : s.min_us;
}

std::string PythonServerClamp(const models::RobotConfig& config) {
  std::ostringstream o;
  o << "# Servo limits of " << config.name << " (owlcal), as the Pi server's Python packet loop\n"
    << "# clamps them (Owl user guide, code snippet 4). Paste after the fields are read.\n"
    << "# range check to prevent servo overdrive\n";
  // The guide's order: Ry, Rx, Ly, Lx, Neck; the upper bound first.
  for (int s : {models::kRy, models::kRx, models::kLy, models::kLx, models::kNeck}) {
    const models::ServoConfig& c = config.servos[s];
    o << "if (" << c.name << ">" << c.max_us << "):\n    " << c.name << " = " << c.max_us << "\n";
    o << "if (" << c.name << "<" << c.min_us << "):\n    " << c.name << " = " << c.min_us << "\n";
  }
  return o.str();
}

std::string CServerRanges(const models::RobotConfig& config) {
  using models::kLx;
  using models::kLy;
  using models::kNeck;
  using models::kRx;
  using models::kRy;
  auto end = [&](int s, bool positive) { return ServoEndUs(config, s, positive); };
  std::ostringstream o;
  o << "// Servo limits of " << config.name << " (owlcal), in the form of the Owl user guide's\n"
    << "// code snippet 5 (owl-pwm.h). R/L = the robot's right/left, T/B = top/bottom.\n"
    << "// OWL eye ranges\n"
    << "// SET UP MANUALLY FOR EACH ROBOT\n"
    << "int RyB = " << end(kRy, false) << "; // (bottom) to\n"
    << "int RyT = " << end(kRy, true) << "; // (top)\n"
    << "int RxR = " << end(kRx, true) << "; // (right) to\n"
    << "int RxL = " << end(kRx, false) << "; // (left)\n"
    << "int LyB = " << end(kLy, false) << "; // (bottom) to\n"
    << "int LyT = " << end(kLy, true) << "; // (top)\n"
    << "int LxR = " << end(kLx, true) << "; // (right) to\n"
    << "int LxL = " << end(kLx, false) << "; // (left)\n"
    << "int NeckR = " << end(kNeck, true) << ";\n"
    << "int NeckL = " << end(kNeck, false) << ";\n"
    << "int RxC=" << config.servos[kRx].centre_us << ";\n"
    << "int RyC=" << config.servos[kRy].centre_us << ";\n"
    << "int LxC=" << config.servos[kLx].centre_us << ";\n"
    << "int LyC=" << config.servos[kLy].centre_us << ";\n"
    << "int NeckC = " << config.servos[kNeck].centre_us << ";\n"
    << "int Ry,Rx,Ly,Lx,Neck; // calculate values for position\n"
    << "int RyRange=RyT-RyB;\n"
    << "int RxRange=RxR-RxL;\n"
    << "int LyRange=LyT-LyB; // reflected so negative\n"
    << "int LxRange=LxR-LxL;\n"
    << "int NeckRange=NeckL-NeckR;\n";
  return o.str();
}

}  // namespace owlcal::robot
