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
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/fixation_detector.h"
#include "calib/lk_tracker.h"
#include "calib/target.h"
#include "calib/trial_status.h"
#include "models/robot_config.h"
#include "protocols/protocol.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

// Where is the target in one eye image (pixels, OpenCV convention)?
class TargetLocator {
 public:
  virtual ~TargetLocator() = default;
  // Called with the first frame of a loop (e.g. to cut a template); false = cannot start.
  virtual bool Prepare(const robot::StereoFrame& frame, std::string* why) {
    (void)frame;
    (void)why;
    return true;
  }
  virtual std::optional<Eigen::Vector2d> Locate(const cv::Mat& eye_image, int eye) = 0;
  // The apparent radius [px] of what the last Locate in this eye found (the fixation disc's
  // equivalent radius sqrt(area / pi)); nullopt when it found nothing or the locator does not
  // measure size. Ranging checks it against the target's known size (fitting/ranging_eval.h).
  virtual std::optional<double> LastRadiusPx(int eye) const {
    (void)eye;
    return std::nullopt;
  }
  // Why the last Locate in this eye found nothing ("" when it found the target, or when the
  // locator does not say).
  virtual std::string LastReason(int eye) const {
    (void)eye;
    return "";
  }
  // A hint: the target is expected near px in this eye's next image (where the target is
  // predicted, or where another search found it). Locators that track from their last position
  // search there next; the others ignore it.
  virtual void Expect(int eye, const Eigen::Vector2d& px) {
    (void)eye;
    (void)px;
  }
  virtual std::string Name() const = 0;
};

// Fixation disc/blob (calib/fixation_detector.h).
std::unique_ptr<TargetLocator> MakeFixationLocator(const calib::FixationDetectorOptions& options = {});
// Template cut from the centre of the right eye's image at Prepare (the course's Owl-1 demo:
// the right eye looks at the target, the template is found in both eyes by NCC).
std::unique_ptr<TargetLocator> MakeTemplateLocator(int half_size = 20, double min_score = 0.6);
// The centre of an AprilTag (or chessboard) board found by calib::DetectTarget: the board
// centre mapped through the homography fitted to the detected corners (partial views work).
std::unique_ptr<TargetLocator> MakeBoardLocator(const calib::TargetDefinition& target);
// Lucas-Kanade tracking (calib/lk_tracker.h: pyramidal LK, forward-backward check, refinement
// against the first frame, appearance check). Prepare makes a seed locator (make_seed(), e.g. the
// fixation locator), finds the target in each eye with it and starts a track there; every Locate
// tracks from that eye's previous image. A lost track returns nullopt with LastReason (never the
// stale position). With `reacquire`, a lost eye asks a fresh seed (prepared on that image alone)
// at each later Locate, the frame it is lost included, and restarts the track where the seed finds
// the target; LastReason then starts with "reacquired". Without it the eye stays lost until the
// next Prepare.
std::unique_ptr<TargetLocator> MakeLkLocator(std::function<std::unique_ptr<TargetLocator>()> make_seed,
                                             const calib::LkTrackerOptions& options = {},
                                             bool reacquire = true);
// The target's appearance checked (the LK locator's check, calib/lk_tracker.h, for any locator):
// the first position the inner locator gives in each eye (its "first look", after construction or
// ForgetLook) keeps the window_px square patch around it as the reference; every later position
// must match it with a normalised correlation of at least min_ncc, else that eye's Locate is lost
// (nullopt, LastReason saying the NCC and where). A blob of the wall, a dark image corner or a
// background spot that the inner locator finds when the target is out of view or blurred by a
// saccade scores 0.1-0.8 against the fixation disc on its card; the disc itself 0.93-0.99 across
// the image (lens shading and distortion included), so nothing but the image decides that the
// target is lost. With `reacquire`, a target the inner locator loses or mistakes is searched
// for by NCC template matching of the reference patch (min_ncc), within 4 patches of its last
// checked (or Expect-ed) position first, then over the whole image; the inner
// locator is told to expect it there (Expect) and asked again; LastReason then starts with
// "reacquired".
struct AppearanceCheckOptions {
  // The patch (odd). 0: from the first look's radius r (LastRadiusPx): the odd size nearest 3.5 r,
  // inside the fixation disc's card (side 4 r) so that the wall it moves over stays out (a 41 px
  // patch at 1 m took the wall in and the disc fell to NCC 0.79 as it moved); 41 px when the
  // locator does not measure a radius.
  int window_px = 0;
  double min_ncc = 0.85;
  bool reacquire = true;

  bool Check(std::string* why) const;
};
class AppearanceCheckedLocator : public TargetLocator {
 public:
  AppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner, const AppearanceCheckOptions& options = {});
  bool Prepare(const robot::StereoFrame& frame, std::string* why) override { return inner_->Prepare(frame, why); }
  std::optional<Eigen::Vector2d> Locate(const cv::Mat& eye_image, int eye) override;
  std::optional<double> LastRadiusPx(int eye) const override {
    return found_[eye] ? inner_->LastRadiusPx(eye) : std::nullopt;
  }
  std::string LastReason(int eye) const override { return reason_[eye]; }
  void Expect(int eye, const Eigen::Vector2d& px) override {
    inner_->Expect(eye, px);
    has_last_[eye] = true;
    last_px_[eye] = px;
  }
  std::string Name() const override { return inner_->Name(); }
  // Drops the reference: the next position found becomes the first look.
  void ForgetLook();
  bool has_look(int eye) const { return !look_[eye].empty(); }
  // The NCC of the last position checked in this eye (NaN: none checked).
  double last_ncc(int eye) const { return ncc_[eye]; }

 private:
  std::optional<Eigen::Vector2d> Checked(const cv::Mat& image,
                                         int eye,
                                         const std::optional<Eigen::Vector2d>& p,
                                         std::string* why);
  std::unique_ptr<TargetLocator> inner_;
  AppearanceCheckOptions options_;
  cv::Mat look_[2];  // grey image of the first look
  Eigen::Vector2d look_px_[2];
  int window_px_[2] = {0, 0};        // the patch size in use
  cv::Mat templ_[2];                 // window_px square around the first look (rounded), for reacquisition
  Eigen::Vector2d templ_offset_[2];  // first look minus the template's centre
  bool found_[2] = {false, false};
  bool has_last_[2] = {false, false};
  Eigen::Vector2d last_px_[2];  // the last position that passed the check, or the expected one
  double ncc_[2] = {NAN, NAN};
  std::string reason_[2];
};
std::unique_ptr<AppearanceCheckedLocator> MakeAppearanceCheckedLocator(std::unique_ptr<TargetLocator> inner,
                                                                       const AppearanceCheckOptions& options = {});
// A seed that returns the given pixel per eye ([kLeftEye], [kRightEye]; nullopt = none in that
// eye) for a tracker to start from: MakeLkLocator(MakePixelLocator(...)) fixates a salience
// candidate.
std::unique_ptr<TargetLocator> MakePixelLocator(const std::array<std::optional<Eigen::Vector2d>, 2>& px);

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
