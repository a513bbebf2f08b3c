#pragma once
// The guided jog (owlcal jog): a person finds each servo's maximal range by
// hand, as the course asks ("use the arrow keys to establish the maximal range boundaries"),
// with live position and image feedback, and the result becomes a robot file and the Pi
// server's clamp constants (robot/server_clamp_constants.h).
//
// JogSession is the engine (no terminal: apps/cmd_jog.cc maps keys to these calls):
//   - Step(+1/-1) moves the selected servo by step_us, never beyond its current limits (at
//     the start: the robot file's). A step that would pass a limit does not move; it says which
//     explicit key widens the limit.
//   - Widen(end) is that explicit key: the servo goes to the limit of that end (from inside,
//     backlash taken up) and then widen_step_us beyond it. After every widening step the
//     images are checked with the limits protocol's image motion (protocols/image_motion.h, as
//     protocols/limits_search.h): the travel the image shows since an anchor at the old limit,
//     against the commanded travel (scale measured by a step inward), stops the widening when
//     the image no longer follows (the end-stop: the limit is set where the image stopped, and
//     the servo goes back there), and RimFraction growing by more than rim_fraction over the
//     centre pose stops it at the last pulse without the rim (the eyes only). A limit where
//     the rim already shows is not widened. WidenAuto repeats widening steps until one of
//     those, the envelope or max_auto_steps; when the rim already shows at the limit it
//     narrows instead (steps inward to the first pulse without the rim: "rim").
// The image checks compare with the centre pose in the same scene: a plain, lit, textured
// wall as the limits protocol asks (owlcal jog sets it up with that protocol's placement step).
//   - Confirm() makes the current pulse the limit of its end (the side of the centre it is
//     on), confirmed by the person: to accept a widened limit, or to narrow one (the rim seen
//     by eye).
// Only ends the person confirmed or the images stopped ("confirmed", "end-stop", "rim") change
// in Result(); a widened end nobody confirmed keeps the file's limit (Result's notes say so).
// Nothing is ever commanded outside [envelope_min_us, envelope_max_us]; the robot given must
// accept that envelope (its limits guard clamps to robot.Config(), see MakeJogRobotConfig).
#include <array>
#include <ostream>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "models/robot_config.h"
#include "protocols/limits_search.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

struct JogOptions {
  int step_us = 5;             // one arrow key
  int widen_step_us = 5;       // one widening step beyond a limit
  int envelope_min_us = 1000;  // never commanded outside (four-digit packets; the guide's
  int envelope_max_us = 2150;  // servos take 850..2150 us)
  int settle_ms = 400;         // after every move, before an image is taken
  int scale_step_us = 20;      // inward step that measures the image scale at an anchor
  double rim_fraction = 0.02;  // as the limits protocol
  double min_contrast_grey = 4;
  int max_auto_steps = 80;
  bool Check(std::string* why) const;
};

// The robot file's config with every limit opened to the envelope: what the robot link's
// limits guard is built with during a jog (the jog enforces the file's limits itself).
models::RobotConfig MakeJogRobotConfig(const models::RobotConfig& file, const JogOptions& options);

struct JogEnd {
  int file_us = 0;           // the robot file's limit
  int limit_us = 0;          // the current limit of the session
  std::string how = "file";  // file | widened (not confirmed) | confirmed | end-stop | rim
  std::string message;
  bool Final() const { return how == "confirmed" || how == "end-stop" || how == "rim"; }
};

class JogSession {
 public:
  // `robot` must accept MakeJogRobotConfig(file, options)'s limits. `log` gets one line per
  // event (may be nullptr). Throws std::invalid_argument on bad options.
  JogSession(robot::RobotInterface& robot,
             const models::RobotConfig& file,
             const JogOptions& options,
             std::ostream* log);

  // Centre pose; baseline images (texture and rim) of both eyes. Returns a status text.
  std::string Start();
  void Select(int servo);
  int Selected() const { return servo_; }
  // Each returns one line saying what happened.
  std::string Step(int direction);       // +1 / -1, within the current limits
  std::string GoToLimit(int direction);  // to the current limit of that end
  std::string Widen(int direction);      // one step beyond the limit of that end
  std::string WidenAuto(int direction);  // widening steps until the images stop it
  std::string Confirm();                 // the current pulse becomes its end's limit
  std::string Centre();

  // "Rx 1890 us [1200 file .. 1905 end-stop]" for the selected servo, plus image feedback.
  std::string StatusLine() const;
  const JogEnd& End(int servo, int direction) const { return ends_[servo][direction > 0 ? 1 : 0]; }
  const models::PwmVector& Pose() const { return pose_; }
  // The file's config with the final ends' limits; `notes` (optional) names every end widened
  // but not confirmed (kept at the file's limit).
  models::RobotConfig Result(std::vector<std::string>* notes) const;
  // Every pulse width sent (for tests).
  const std::vector<models::PwmVector>& Sent() const { return sent_; }

 private:
  void Move(int servo, int pulse);
  cv::Mat EyeImage(int servo);
  std::string Log(const std::string& line);
  // Measures the anchor at the current limit of `end` (scale by an inward step). False when
  // the image shows no texture or motion (the widening then goes by the person's eye only).
  bool Anchor(int servo, int direction);
  // One widening step; returns true when the images stopped it (end set) or the rim already
  // shows at the limit (rim_at_limit_, nothing changed).
  bool WidenOnce(int direction, std::string* what);
  // The rim shows at the limit: steps inward until it does not; that pulse is the limit.
  std::string Narrow(int direction);
  // The eye's rim is checked for this servo (an eye servo with a textured image).
  bool RimChecked(int servo) const;

  robot::RobotInterface& robot_;
  models::RobotConfig file_;
  JogOptions o_;
  std::ostream* log_;
  models::PwmVector pose_{};
  int servo_ = models::kRx;
  std::array<std::array<JogEnd, 2>, models::kNumServos> ends_;
  std::vector<models::PwmVector> sent_;
  std::array<double, 2> rim0_{0, 0};
  std::array<bool, 2> textured_{false, false};
  int64_t last_stamp_ = 0;
  // Widening state of one end.
  int anchor_servo_ = -1, anchor_dir_ = 0, anchor_us_ = 0;
  cv::Mat anchor_thumb_;
  double scale_ = 0, sign_ = 1;
  StopDetector stop_{8.0, 2.0};
  bool image_check_ = false;
  double last_shift_px_ = 0, last_rim_ = 0, anchor_rim_ = 0, last_travel_ = 0;
  bool rim_at_limit_ = false;
};

}  // namespace owlcal::protocols
