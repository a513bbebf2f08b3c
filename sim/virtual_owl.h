#pragma once
// The virtual Owl: a ground-truth robot behind robot::RobotInterface. It reads a robot-truth file
// (sim/robot_truth.h) and a scene file (sim/scene.h), simulates the five servos exactly
// (sim/servo_dynamics.h) and renders the 1280x480 side-by-side stream (sim/renderer.h) with JPEG
// artefacts, noise, latency and drops.
//
// Clock. In-process (default) the clock is VIRTUAL and starts at 0: it advances only in
// SleepNs, SendServos (by stream.servo_reply_ms, the packet round trip) and GrabFrame.
// With real_time = true (served mode) NowNs is the host's steady clock since construction
// and waits really sleep.
//
// Stream timing. Frame `seq` (0, 1, ...) is exposed at ExposureNs(seq, eye) = seq / fps (+
// stream.eye_offset_ms for the right eye) and received at StampNs(seq) = seq / fps + latency (+ the
// eye offset if positive: the frame is complete when both eyes are). GrabFrame(after, timeout)
// returns the newest received frame whose stamp > after; if there is none yet it advances the clock
// to the delivery of the next one (skipping dropped frames), or by `timeout` and returns nullopt.
// Each frame shows the servo angles at its exposure time, so a command reaches the image after the
// latency. Frames depend only on (seed, seq, command history, scene): two runs with the same seed
// and calls produce identical frames.
//
// Commands. SendServos clamps each value to the robot file's limits (the course server's
// clamp; Config() is truth.robot), applies them at NowNs() and answers "ok".
//
// Thread safety: all public methods may be called from several threads (served mode).
//
// Usage:
//   VirtualOwl owl({});                       // built-in default robot and scene
//   owl.SendServos(owl.Config().Centre());
//   owl.SleepNs(500'000'000);
//   auto frame = owl.GrabFrame(owl.NowNs(), 1'000'000'000);
//   FrameTruth truth = owl.TruthForFrame(frame->seq);
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "models/head_model.h"
#include "robot/robot_interface.h"
#include "sim/renderer.h"
#include "sim/robot_truth.h"
#include "sim/scene.h"
#include "sim/servo_dynamics.h"

namespace owlcal::sim {

struct VirtualOwlOptions {
  std::string truth_file;  // empty = built-in default robot truth (data/sim/owl_default_truth.yaml)
  std::string scene_file;  // empty = built-in default scene
  uint64_t seed = 1;
  // Used instead of the files when set.
  std::optional<RobotTruth> truth;
  std::optional<SceneDescription> scene;
  // Overrides of the truth file's stream/servo settings.
  std::optional<double> latency_ms;
  std::optional<double> noise_sigma;  // grey levels; 0 = no noise
  std::optional<double> drop_probability;
  std::optional<double> eye_offset_ms;
  std::optional<int> jpeg_quality;
  std::optional<int> quantum_us;  // all five servos (1, or 5 as pigpio)
  bool encode_jpeg = true;        // false: StereoFrame.jpeg stays empty, halves are the raw render
  bool decode_frames = true;      // false: StereoFrame.left/right stay empty (served mode)
  bool real_time = false;         // served mode: the host's clock
  bool Check(std::string* why) const;
};

// What was true for one frame: exposure times and joint angles per eye, camera poses.
struct FrameTruth {
  int64_t seq = 0;
  int64_t stamp_ns = 0;
  int64_t exposure_ns[2] = {0, 0};  // [kLeftEye], [kRightEye]
  models::JointAngles angles[2];    // the joint angles at each eye's exposure
  models::Rigid3d cam_from_base[2];
};

class VirtualOwl : public robot::RobotInterface, public robot::SceneControl {
 public:
  // Throws std::invalid_argument (bad options) or std::runtime_error (unreadable files).
  explicit VirtualOwl(const VirtualOwlOptions& options);
  ~VirtualOwl() override;

  // RobotInterface.
  const models::RobotConfig& Config() const override { return truth_.robot; }
  robot::ServoReply SendServos(const robot::PwmVector& pwm_us) override;
  std::optional<robot::StereoFrame> GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) override;
  int64_t NowNs() override;
  void SleepNs(int64_t ns) override;
  robot::SceneControl* Scene() override { return this; }
  std::string Describe() const override;

  // SceneControl.
  void SetTargetPose(const std::string& name, const Eigen::Isometry3d& base_from_target) override;
  std::optional<Eigen::Isometry3d> TargetPose(const std::string& name) const override;
  std::vector<std::string> TargetNames() const override;
  std::string TruthJson() const override;
  std::optional<models::HeadModel> TruthHead() const override { return head_; }
  std::optional<std::array<models::JointAngles, 2>> TruthAnglesForFrame(int64_t seq) const override;
  // Shows or hides a target (a person taking a board away). Throws on an unknown name.
  void SetTargetVisible(const std::string& name, bool visible);
  // Makes a target still (default) or held by a person (sim/scene.h TargetMotion). Throws on an
  // unknown name or speeds out of range.
  void SetTargetMotion(const std::string& name, const TargetMotion& motion);

  // Truth.
  models::HeadModel TruthHeadModel() const { return head_; }
  const RobotTruth& Truth() const { return truth_; }
  SceneDescription SceneState() const;
  uint64_t seed() const { return seed_; }

  // The true joint angles at time t_ns (not before ~10 s of history), and per servo [rad].
  models::JointAngles JointAnglesAt(int64_t t_ns) const;
  std::array<double, models::kNumServos> ServoAnglesAt(int64_t t_ns) const;
  // The last command after the clamp (what the servos were told).
  robot::PwmVector LastCommand() const;
  // cam_from_base for an eye at given joint angles: exactly models::HeadModel's chain.
  models::Rigid3d CamFromBase(models::Eye eye, const models::JointAngles& angles) const;

  // Stream timing and per-frame truth (deterministic functions of seq and the history).
  int64_t ExposureNs(int64_t seq, models::Eye eye) const;
  int64_t StampNs(int64_t seq) const;
  bool IsDropped(int64_t seq) const;
  FrameTruth TruthForFrame(int64_t seq) const;
  // Renders frame `seq` as the stream would deliver it (the clock does not move).
  robot::StereoFrame RenderFrame(int64_t seq) const;
  // Renders one eye's noise-free grey image at given joint angles (tests, benchmarks), and
  // optionally the truth depth image (EyeRenderer::Render: camera z [m], CV_32F).
  cv::Mat RenderEyeGrey(models::Eye eye, const models::JointAngles& angles, cv::Mat* depth_z_m = nullptr) const;
  // Eye images the stream has rendered so far; a still head and scene reuse the last one (EyeGrey).
  int64_t NumEyeRenders() const { return num_eye_renders_.load(); }

 private:
  int64_t NowLocked() const;
  void AdvanceTo(int64_t t_ns, std::unique_lock<std::mutex>* lock);
  int64_t NewestReceivedSeq(int64_t t_ns) const;
  robot::StereoFrame Compose(int64_t seq,
                             const FrameTruth& ft,
                             const SceneDescription& scene,
                             uint64_t scene_revision) const;
  // One eye's noise-free image, reused from the last render when the scene has not changed, no
  // target moves and the camera has moved less than kReuseAngle_rad / kReuseShift_m since.
  cv::Mat EyeGrey(models::Eye eye, const FrameTruth& ft, const SceneDescription& scene, uint64_t scene_revision) const;

  RobotTruth truth_;
  models::HeadModel head_;
  uint64_t seed_;
  bool encode_jpeg_;
  bool decode_frames_;
  bool real_time_;
  std::chrono::steady_clock::time_point start_;
  SceneDescription scene_;
  std::vector<std::unique_ptr<TargetTexture>> textures_;  // per scene target
  TargetTexture background_;
  std::unique_ptr<EyeRenderer> renderers_[2];

  mutable std::mutex mutex_;
  int64_t now_ns_ = 0;
  std::vector<ServoDynamics> servos_;
  robot::PwmVector last_command_{};
  mutable std::optional<robot::StereoFrame> cached_frame_;
  uint64_t scene_revision_ = 0;  // counts the changes to scene_

  // The last noise-free render of each eye and what it showed (EyeGrey).
  struct RenderedEye {
    bool valid = false;
    uint64_t scene_revision = 0;
    models::Rigid3d cam_from_base;
    cv::Mat grey;
  };
  mutable std::mutex rendered_mutex_[2];
  mutable RenderedEye rendered_[2];
  mutable std::atomic<int64_t> num_eye_renders_{0};
};

}  // namespace owlcal::sim
