#pragma once
// Does the robot file agree with what the head fit measured?
//
// The robot file (data/robots/*.yaml) states the design IPD, each servo's centre pulse width,
// its direction and its deg/us. A real Owl differs from its file: a fitted value far from the
// file means the file should be updated, and every number owlcal derives from the file alone
// (the course's nominal ranging, the limits in degrees, owl-pwm.h's nominal map) is off by as
// much. A disagreement is reported when it is beyond 3 sigma of the fit AND beyond a physical
// tolerance (so a well-determined fit on a good file stays quiet), e.g.
//   "IPD 67.05 +- 0.12 mm, robot file says 65.0 mm".
// A fitted scale of the other sign than the file's direction is always reported: the file's
// direction is wrong.
#include <string>
#include <vector>

#include "fitting/result.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct RobotFileTolerance {
  double ipd_mm = 0.5;           // 0.5 mm: 1 % of range at the vergence protocol's distances
  double centre_us = 10;         // ~1.1 deg at the guide's 0.113 deg/us
  double scale_fraction = 0.03;  // 3 % of deg/us: 0.6 deg over a 20 deg saccade
  double n_sigma = 3;
  bool Check(std::string* why) const;
};

struct RobotFileDisagreement {
  std::string what;       // "IPD", "Rx centre", "Ly scale", "Ly direction"
  std::string parameter;  // results.json parameter name ("head.ipd_mm")
  double fitted = 0, sigma = 0, file = 0;
  std::string unit;
  std::string item;     // short, for a grouped list: "Rx 1556.96 ± 0.26 µs, file 1545 µs (1.4°)"
  std::string message;  // one line on its own, with the fix
};

// Compares the fitted head parameters (head.ipd_mm, servo.X.centre_us, servo.X.deg_per_us) with
// the robot file. Parameters that are missing, not determined or not finite are skipped (they
// say nothing about the file).
std::vector<RobotFileDisagreement> CompareWithRobotFile(const CalibrationResult& fitted,
                                                        const models::RobotConfig& robot,
                                                        const RobotFileTolerance& tolerance = {});

// The disagreements as warnings for results.json and the report, grouped so that a robot file
// that is off everywhere gives three lines, not ten: the IPD, the centres, the scales and
// directions. Empty when the file agrees.
std::vector<std::string> RobotFileWarnings(const std::vector<RobotFileDisagreement>& disagreements);

}  // namespace owlcal::fitting
