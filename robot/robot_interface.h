#pragma once
// The robot interface shared by the real Owl (robot/owl_link.h: TCP servo link + MJPEG
// stream) and the virtual Owl (sim/). Protocols talk only to this.
//
// Time: every robot has a clock (NowNs, SleepNs). The real one is the host's steady clock;
// the in-process virtual Owl runs a virtual clock that advances only when SleepNs or
// GrabFrame wait, so runs are deterministic and faster than real time.
//
// Safety: SendServos never lets a value outside the robot file's limits reach the wire
// (implementations pass commands through LimitsGuard, robot/limits_guard.h).
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::robot {

using models::PwmVector;

struct StereoFrame {
  int64_t seq = 0;            // stream sequence number (gaps = dropped frames)
  int64_t stamp_ns = 0;       // receive time on the robot's clock (no hardware stamp exists)
  std::vector<uint8_t> jpeg;  // the side-by-side frame as received (1280x480 MJPEG frame)
  cv::Mat left, right;        // decoded 640x480 BGR halves, after the configured swap/mirror
};

struct ServoReply {
  bool ok = false;       // a reply arrived before the timeout
  std::string text;      // what the server answered ("ok", or the Rx value on a C server)
  PwmVector sent{};      // what was put on the wire, after the limits guard
  bool clamped = false;  // the guard changed at least one value
};

// Scene control: what a person does on a real robot (move a target), and the truth a
// virtual robot can tell. Real robots return nullptr from RobotInterface::Scene().
class SceneControl {
 public:
  virtual ~SceneControl() = default;
  // Places target `name` with pose base_from_target (base frame: models/head_kinematics.h).
  virtual void SetTargetPose(const std::string& name, const Eigen::Isometry3d& base_from_target) = 0;
  virtual std::optional<Eigen::Isometry3d> TargetPose(const std::string& name) const = 0;
  virtual std::vector<std::string> TargetNames() const = 0;
  // Full ground truth as JSON text (robot truth, scene, servo states).
  virtual std::string TruthJson() const = 0;
  // The true head (servo maps, geometry, lenses) and the true joint angles at each eye's
  // exposure of stream frame `seq` ([kLeftEye], [kRightEye]): what a measurement made from that
  // frame is compared with. nullopt where no truth exists.
  virtual std::optional<models::HeadModel> TruthHead() const { return std::nullopt; }
  virtual std::optional<std::array<models::JointAngles, 2>> TruthAnglesForFrame(int64_t seq) const {
    (void)seq;
    return std::nullopt;
  }
};

class RobotInterface {
 public:
  virtual ~RobotInterface() = default;
  virtual const models::RobotConfig& Config() const = 0;
  // Sends one servo command (clamped to the limits); waits for the reply.
  virtual ServoReply SendServos(const PwmVector& pwm_us) = 0;
  // The newest frame received after `after_stamp_ns` (waits up to timeout_ns); nullopt on timeout.
  virtual std::optional<StereoFrame> GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) = 0;
  virtual int64_t NowNs() = 0;
  virtual void SleepNs(int64_t ns) = 0;
  virtual SceneControl* Scene() { return nullptr; }
  // A short description for logs and manifests ("virtual Owl seed 1", "127.0.0.1:12345").
  virtual std::string Describe() const = 0;
};

}  // namespace owlcal::robot
