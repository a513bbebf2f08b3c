#pragma once
// A robot seen through another configuration: Config() is `config` (limits, centres, directions),
// everything else is the wrapped robot's. Calibrate runs the protocols after its bring-up on the
// configuration it learned (pipeline/bring_up.h) this way, in memory: the robot file on disk and
// the robot's own limits stay as they are, and the limits guard of every later protocol
// (protocols/run_context.h) confines commands to the learned range. The stream layout fields of
// `config` must be the wrapped robot's (frames are not re-split here).
#include <string>
#include <utility>

#include "robot/robot_interface.h"

namespace owlcal::robot {

class ReconfiguredRobot : public RobotInterface {
 public:
  ReconfiguredRobot(RobotInterface& robot, models::RobotConfig config) : robot_(robot), config_(std::move(config)) {}
  const models::RobotConfig& Config() const override { return config_; }
  ServoReply SendServos(const PwmVector& pwm_us) override { return robot_.SendServos(pwm_us); }
  std::optional<StereoFrame> GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) override {
    return robot_.GrabFrame(after_stamp_ns, timeout_ns);
  }
  int64_t NowNs() override { return robot_.NowNs(); }
  void SleepNs(int64_t ns) override { robot_.SleepNs(ns); }
  SceneControl* Scene() override { return robot_.Scene(); }
  std::string Describe() const override { return robot_.Describe() + " (learned configuration)"; }

 private:
  RobotInterface& robot_;
  models::RobotConfig config_;
};

}  // namespace owlcal::robot
