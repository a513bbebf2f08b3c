#pragma once
// What a protocol run's step loop (protocols/runner.cc) shares with its measurement procedures
// (protocols/*_step.h): the robot link, every command through the limits guard, the frames
// recorded into the dataset (with the detection of `detect: true` steps), settling and progress.
//
// A procedure is a free function `void RunXStep(RunContext& run, const Protocol& p, const Step& s)`
// that moves the robot only through Send(), reads images only through Grab() (Record() to keep
// them in the dataset) and writes its measurement table through writer().AppendRow (runner.h
// lists the tables). It throws to fail its step; RunAborted ends the run as "aborted".
#include <array>
#include <chrono>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/csv.h"
#include "io/number_text.h"
#include "models/head_model.h"
#include "models/robot_config.h"
#include "protocols/coverage.h"
#include "protocols/dataset.h"
#include "protocols/fixation.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/limits_guard.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

// A stop request (RunOptions::stop_flag) or a prompt left without an answer: the run parks the
// head and closes the dataset as "aborted".
struct RunAborted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Why the run stops: the signal that set InstallStopSignals()'s flag, named (runner.cc).
std::string StopReason();

// `v` with `prec` digits after the point (progress lines, events and table cells).
using io::FixedText;
// The five pulse widths in wire order, space separated.
std::string PwmText(const models::PwmVector& p);
// The eye whose image shows a servo's motion, and the image axis it moves along (0 = x, 1 = y).
int ServoEye(int servo);
int ServoAxis(int servo);

class RunContext {
 public:
  RunContext(robot::RobotInterface& robot, const RunOptions& options);

  robot::RobotInterface& robot() { return robot_; }
  const RunOptions& options() const { return o_; }
  const models::RobotConfig& config() const { return config_; }
  DatasetWriter& writer() { return *writer_; }
  // The last command sent (after the limits guard) and the sign of each servo's last move.
  const models::PwmVector& cmd() const { return cmd_; }
  const std::array<int8_t, models::kNumServos>& approach() const { return approach_; }
  // The joint angles `head` gives for the command `cmd` with each servo's last approach side.
  models::JointAngles AnglesAt(const models::HeadModel& head, const models::PwmVector& cmd) const {
    std::array<double, models::kNumServos> u{};
    std::array<int, models::kNumServos> ap{};
    for (int i = 0; i < models::kNumServos; ++i) {
      u[i] = cmd[i];
      ap[i] = approach_[i];
    }
    return head.Angles(u, ap);
  }
  int step_index() const { return step_index_; }
  const std::string& step_name() const { return step_name_; }
  // The placement in force (placements.csv row), -1 before the first place-target step.
  int placement_index() const { return placement_index_; }
  void set_placement_index(int index) { placement_index_ = index; }
  // Progress within the current step (0..1), for the ETA.
  void set_step_work_fraction(double f) { step_work_fraction_ = f; }

  // Throws RunAborted when a stop was requested.
  void CheckStop();
  // Sends a command through the limits guard (a clamp is counted and reported); throws when
  // the robot does not reply.
  void Send(const models::PwmVector& desired);
  // Sends `target` and waits by `rule`, unless a servo would come within `margin_us` of its
  // configured limits: then nothing is sent and the reason is returned (models::OutsideMargin's
  // message ending in `what`, e.g. "not sent"); "" when it was sent.
  std::string SendWithinMargin(const models::PwmVector& target,
                               int margin_us,
                               const std::string& what,
                               const SettleRule& rule);
  // The next frame newer than the last one; throws after RunOptions::frame_timeout_ns.
  robot::StereoFrame Grab();
  // Appends the frame to the dataset with the current command; returns its frame index.
  int64_t Record(const robot::StereoFrame& f);
  // A line in events.log.
  void Event(const std::string& kind, const std::string& message);
  // Waits until the robot settled after the last command; false on a settle timeout.
  bool Settle(const SettleRule& rule);
  void CaptureFrames(int n);
  void MoveSettleCapture(const models::PwmVector& pose, const SettleRule& rule, int frames);
  // Runs the fixation loop (protocols/fixation.h) on this robot; record = keep its frames in
  // the dataset, frame_indices = their indices (-1 when not recorded).
  FixationResult Fixate(const FixationOptions& fo,
                        TargetLocator& loc,
                        bool record,
                        std::vector<int64_t>* frame_indices);
  // A progress line (at most every RunOptions::progress_every_s unless forced).
  void Progress(bool force);

 protected:
  // Detects the protocol's target in both eyes of a recorded frame: observations.csv and the
  // coverage views.
  void Detect(const robot::StereoFrame& f, int64_t index);
  void WriteCoverage();

  robot::RobotInterface& robot_;
  const RunOptions& o_;
  models::RobotConfig config_;
  robot::LimitsGuard guard_;
  size_t num_steps_ = 0;
  std::unique_ptr<DatasetWriter> writer_;
  models::PwmVector cmd_{};
  bool cmd_known_ = false;
  std::array<int8_t, models::kNumServos> approach_{};
  int placement_index_ = -1;
  int step_index_ = -1;
  std::string step_name_;
  int64_t last_stamp_ = -1;
  int64_t step_frames_ = 0;
  RunSummary summary_;
  const Step* cur_step_ = nullptr;
  const Protocol* cur_protocol_ = nullptr;
  std::vector<ViewParams> coverage_views_[2];
  bool detected_any_ = false;
  std::chrono::steady_clock::time_point wall_start_, last_progress_;
  double total_work_ = 0, done_work_ = 0, current_work_ = 0, step_work_fraction_ = 0;
};

}  // namespace owlcal::protocols
