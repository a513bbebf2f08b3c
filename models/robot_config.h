#pragma once
// One robot's servo configuration as data: limits, centres, directions and the nominal
// scale of each of the five servos, in the order of the wire packet (Rx Ry Lx Ly Neck).
// Loaded from a robot file by robot/robot_file.h; the guide's robot is DefaultRobotConfig().
#include <array>
#include <string>

namespace owlcal::models {

enum ServoIndex { kRx = 0, kRy = 1, kLx = 2, kLy = 3, kNeck = 4 };
inline constexpr int kNumServos = 5;
inline constexpr std::array<const char*, kNumServos> kServoNames = {"Rx", "Ry", "Lx", "Ly", "Neck"};

// Pulse widths in wire order [us].
using PwmVector = std::array<int, kNumServos>;

struct ServoConfig {
  std::string name;
  int min_us = 1000;     // lowest pulse width ever sent
  int max_us = 2000;     // highest pulse width ever sent
  int centre_us = 1500;  // straight ahead / level
  // Sign of the joint angle per increasing PWM, with angles positive to the robot's right
  // (pan, neck) and up (tilt). Guide and docs/conventions.md, Facts: Rx, Lx +1 (right), Ry +1 (up),
  // Ly -1 (mirrored: increasing PWM moves down), Neck -1 (increasing PWM turns left).
  int direction = 1;
  double nominal_deg_per_us = 0.113;

  int Clamp(int us) const { return us < min_us ? min_us : (us > max_us ? max_us : us); }
};

struct RobotConfig {
  std::string name = "guide-owl";
  std::array<ServoConfig, kNumServos> servos;
  double ipd_m = 0.065;   // design inter-pupillary distance
  int image_width = 640;  // per eye
  int image_height = 480;
  // Stream layout. A real Owl's stream arrives mirrored (the course code flips the whole
  // 1280x480 frame, then left eye = columns 0-639), so mirror_stream is true by default.
  bool swap_eyes = false;     // true: left eye = columns 640-1279 (after the flip if mirrored)
  bool mirror_stream = true;  // true: the stream frame is flipped horizontally first

  PwmVector Centre() const {
    PwmVector c{};
    for (int i = 0; i < kNumServos; ++i) c[i] = servos[i].centre_us;
    return c;
  }
};

// "" when every servo of `target` is at least margin_us [us] inside `robot`'s configured limits
// (servos at their value in *unchanged_from are not checked, when given); else which servo would
// come within the margin, ending with `then` (what the caller does instead of sending).
inline std::string OutsideMargin(const RobotConfig& robot,
                                 const PwmVector& target,
                                 int margin_us,
                                 const std::string& then,
                                 const PwmVector* unchanged_from = nullptr) {
  for (int i = 0; i < kNumServos; ++i) {
    if (unchanged_from && target[i] == (*unchanged_from)[i]) continue;
    const ServoConfig& c = robot.servos[i];
    if (target[i] < c.min_us + margin_us || target[i] > c.max_us - margin_us)
      return std::string(kServoNames[i]) + " would go to " + std::to_string(target[i]) + " us, within " +
             std::to_string(margin_us) + " us of its limit [" + std::to_string(c.min_us) + ", " +
             std::to_string(c.max_us) + "]: " + then;
  }
  return "";
}

// The robot of the Owl user guide (code snippets 4 and 5).
inline RobotConfig DefaultRobotConfig() {
  RobotConfig r;
  r.servos[kRx] = {"Rx", 1200, 1890, 1545, +1, 0.113};
  r.servos[kRy] = {"Ry", 1120, 2000, 1530, +1, 0.113};
  r.servos[kLx] = {"Lx", 1180, 1850, 1545, +1, 0.113};
  r.servos[kLy] = {"Ly", 1180, 2000, 1580, -1, 0.113};
  r.servos[kNeck] = {"Neck", 1100, 1950, 1530, -1, 0.113};
  return r;
}

}  // namespace owlcal::models
