#pragma once
// Closed-loop fixation: proportional control from the target's image offset to a PWM change,
// as in the course (guide, "Proportional Control"; Owl-1 demo), with the gain, latency
// awareness and a divergence stop.
//
// Each update, for every controlled eye, the target's offset from the image centre
// e = (u - cx, v - cy) [px] (cx = (width - 1) / 2) is converted to a pulse-width error with
// the nominal camera and servo scales:
//   pan_err_us  = direction_pan  * deg(atan(e_x / focal_px)) / deg_per_us
//   tilt_err_us = direction_tilt * deg(atan(-e_y / focal_px)) / deg_per_us
// and the command moves by gain * error (the course's incremental loop theta += K * error,
// docs/conventions.md, Facts "Control with latency": with d frames of delay K_crit = 2 sin(pi / (2
// (2d + 1))), 0.445 for d = 3; K = 0.1 settles without overshoot). The command is kept as a real
// number and rounded to whole microseconds when sent. An axis whose offset is within tolerance_px
// is not updated (a dead zone: with servo backlash an integrating loop would limit-cycle). Once an
// axis' offset has cycled across the centre (two sign changes within 16 px: a reversal smaller than
// the backlash makes the virtual Owl's joint jump the wrong way by up to 2 hysteresis - 1 step, 13 px
// on variant A), its dead zone takes in
// the plateaus the target jumped between: a servo with a PWM step or dead band cannot put it
// closer, and the loop would otherwise cycle between two pulses for ever.
//
// Latency awareness: latency_frames = n > 0 waits n frames after every update (those frames
// still show the old pose), which makes large gains stable at the cost of a slower loop.
//
// Seating (seat_grid_us > 0): a servo with a PWM step or a dead band applies a pulse that
// differs from the last command by up to half a step or the dead band, and which one depends on
// the commands before (models/servo_resolution.h); ranging at the command is then off by about
// 3 % per us of pan at 1 m (and by up to 2 % from the tilt: the gaze ray through an off-centre
// pixel turns with it). Once converged, each controlled servo's command is snapped to the
// nearest multiple of seat_grid_us (a multiple of the PWM step is produced exactly, whatever the
// generator's rounding) and reached with one move of seat_back_us, larger than any dead band up
// to seat_back_us, from the side the loop last came from (the same backlash; below when
// unknown, the other side near a limit). The servo then applies exactly the command with a
// known approach: the settled command IS the applied pulse on every robot whose PWM step
// divides seat_grid_us (1 or 5 us) and whose dead band is at most seat_back_us. An axis left
// more than half a grid step off is moved by whole grid steps and seated once more. The mean
// offsets of the last seat_average of seat_frames frames are the residuals that ranging refines
// the gaze with; the target not found in any of them is a lost target.
//
// Divergence stop: the loop stops (and reports why) BEFORE sending a command that would come
// within limit_margin_us of a servo's limit, when the error's half-cycle peaks grow twice in
// a row (an oscillation building up), when the error grows beyond twice its initial
// value, or when the target is lost for lost_frames frames.
#include <array>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/trial_status.h"
#include "models/robot_config.h"
#include "protocols/protocol.h"
#include "protocols/target_locator.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

struct FixationOptions {
  bool eyes[2] = {true, true};   // [kLeftEye], [kRightEye]
  bool pan = true, tilt = true;  // axes controlled
  double gain = 0.1;
  int max_iterations = 90;  // frames (updates + waits)
  bool stop_when_converged = true;
  double tolerance_px = 1.0;  // converged: |e| <= tolerance with the command unchanged
  int still_frames = 4;       //   for this many consecutive frames
  int latency_frames = 0;
  int max_step_us = 60;  // per update and servo
  int limit_margin_us = 20;
  int lost_frames = 5;
  double focal_px = 585;  // nominal focal length: NominalFocalPx()
  int seat_grid_us = 5;   // 0: no seating (see the header comment)
  int seat_back_us = 10;
  int seat_frames = 12;  // frames after the seating move: latency + slew + lag
  int seat_average = 3;

  bool Check(std::string* why) const;
};

struct FixationSample {
  int k = 0;  // frame number in the loop
  int64_t stamp_ns = 0;
  bool found[2] = {false, false};
  Eigen::Vector2d offset_px[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};  // target - centre
  models::PwmVector pwm_us{};          // command in force when the frame arrived
  std::optional<double> radius_px[2];  // apparent target radius (TargetLocator::LastRadiusPx)
};

struct FixationResult {
  enum class Outcome { kConverged, kMaxIterations, kDiverged, kLimit, kLost, kNotStarted };
  Outcome outcome = Outcome::kNotStarted;
  std::string message;
  int iterations = 0;
  models::PwmVector final_pwm_us{};
  bool found[2] = {false, false};
  Eigen::Vector2d residual_px[2] = {Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()};  // last offsets
  // The target's apparent radius over the same frames as the residual; nullopt when the
  // locator does not measure it.
  std::optional<double> radius_px[2];
  std::vector<FixationSample> trace;
  bool seated = false;  // the settled command was seated (see FixationOptions)
};
const char* OutcomeName(FixationResult::Outcome outcome);

// The nominal focal length [px] the controllers turn image offsets into angles with: 585 px at
// 640 columns (docs/conventions.md, "Ranging error budget"), scaled with the image width. The
// fixation loop, the limits and latency steps, jog's image check and the settling study's loop
// model all use it.
double NominalFocalPx(const models::RobotConfig& robot);

// The trial status (calib/trial_status.h) of a fixation and why: converged with the target
// found in every controlled eye = ok; out of frames, diverged or stopped before a limit = not
// settled; the target lost (or missing in a controlled eye at the end) = lost target; could not
// start = failed. *reason is empty for ok.
calib::TrialStatus FixationStatus(const FixationResult& result, const FixationOptions& options, std::string* reason);

// What the loop needs from the runner: the command in force, sending through the limits
// guard, and the next frame (throws on timeout or abort).
struct FixationIo {
  std::function<models::PwmVector()> command;
  std::function<void(const models::PwmVector&)> send;
  std::function<robot::StereoFrame()> grab;
};

FixationResult RunFixation(const FixationOptions& options,
                           const models::RobotConfig& robot,
                           TargetLocator& locator,
                           const FixationIo& io);

// The pulse-width change that would centre an image offset for one eye (the loop's error
// term before the gain): [pan_us, tilt_us] on servos kPanServo[eye], kTiltServo[eye].
Eigen::Vector2d OffsetToPulseError(const Eigen::Vector2d& offset_px,
                                   int eye,
                                   const models::RobotConfig& robot,
                                   double focal_px);

}  // namespace owlcal::protocols
