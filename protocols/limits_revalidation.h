#pragma once
// Re-validation of a robot file's limits (owlcal jog, after it wrote a new robot file): the
// standard limits protocol (protocols/standard/limits.yaml, protocols/limits_search.h) runs on
// a robot configured with that file, and each servo passes when, at both ends, the search
// measured the end (status ok) no more than tolerance_us inside the file's limit: the robot
// reaches its new limits with the image following, so they are neither past an end-stop nor
// into the socket rim. The dataset goes to out_dir (limits.csv holds the probes).
#include <ostream>
#include <string>
#include <vector>

#include "protocols/runner.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

struct ServoRevalidation {
  int servo = 0;
  bool pass = false;
  int limit_us[2] = {0, 0};     // the file's min, max
  int measured_us[2] = {0, 0};  // the search's (0 when it failed)
  std::string cause[2];         // end-stop | rim | configured | failed
  std::string message;          // why it failed, or "both ends reached"
};

struct RevalidationOptions {
  std::vector<int> servos{0, 1, 2, 3, 4};
  int tolerance_us = 10;
  std::ostream* progress = nullptr;
  bool Check(std::string* why) const;
};

// Runs the steps of the limits protocol before its limits step (the scene it needs: every target
// taken away, a plain textured wall; a person is prompted when options.interactive) and records
// them in options.out_dir. The image checks of owlcal jog compare images in that scene.
RunSummary SetUpLimitsScene(robot::RobotInterface& robot, const RunOptions& options);

// Runs the limits protocol on `robot` (whose Config() is the file to check). Throws on bad
// options or an unreadable protocol; a failed search is a failing servo, not an exception.
std::vector<ServoRevalidation> RevalidateLimits(robot::RobotInterface& robot,
                                                const std::string& out_dir,
                                                const RevalidationOptions& options);

}  // namespace owlcal::protocols
