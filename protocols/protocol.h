#pragma once
// Experiment protocols: YAML files a user can copy and edit (protocols/standard/*.yaml are the
// standard suite; each file documents itself). A protocol is a name, the target it expects
// and a list of steps; `repeat` blocks are expanded when the file is loaded, so a loaded
// protocol is a flat list of steps.
//
// File format (every key below; unknown keys are errors):
//
//   name: servo_sweep                  # required
//   description: "..."                 # optional free text
//   target: board                      # the scene target the protocol expects (a name); the
//                                      # prompt on a real robot says which physical target
//   target_description: "9x6 chessboard, 26 mm squares"   # optional, used in prompts
//   targets:                           # optional geometry of named targets (calib/target_file.h
//     board: {target_type: chessboard, cols: 9, rows: 6, square_size_m: 0.026}   # keys)
//   tag_targets: [tags_right_up]       # optional: AprilGrids of `targets` fixed in the scene (not
//                                      # moved by place-target, never hidden by hide_others) and
//                                      # detected with `target` in every `detect: true` frame,
//                                      # where the board has left the view too (partial grids count)
//   steps:
//     - move-to: {pose: {Rx: centre, Lx: centre+50, Neck: 1530}, settle: {...}}
//     - sweep: {servo: Rx, from: centre-150, to: centre+150, step_us: 25,
//               both_directions: true, frames: 1, settle: {...}, hold: {pose...}, detect: false,
//               tags: true}        # tags: false searches its frames for `target` only, not the tag_targets
//     - grid: {eyes: both, pan_us: [-100, 0, 100], tilt_us: [-60, 0, 60], neck_us: [0],
//              frames: 1, settle: {...}, detect: false}
//     - place-target: {target: board, distance_m: 0.6, offset_m: [0, 0], rpy_deg: [0, 20, 0],
//                      hide_others: true, prompt: "..."}
//     - capture: {frames: 5, settle: {...}, detect: true}
//     - fixate: {eyes: both, locator: fixation|template|apriltag|lk, gain: 0.1, max_iterations: 90,
//                (fixation: the disc detector; template: NCC of the right eye's centre patch;
//                 apriltag: the centre of the protocol's `target` board via calib::DetectTarget;
//                 lk: Lucas-Kanade tracking seeded by the disc detector, protocols/fixation.h)
//                tolerance_px: 0.5, still_frames: 4, latency_frames: 0, max_step_us: 60,
//                limit_margin_us: 20, record_frames: false, from: current|centre}
//     - step-response: {eye: right, axis: pan, amplitudes_deg: [5, 10, 20], gains: [0.05, 0.1],
//                       frames: 45, locator: fixation, trials: 1, record_frames: false}
//     - limits: {servos: [Rx, Ry, Lx, Ly, Neck], coarse_us: 20, fine_us: 2, frames: 1,
//                moved_fraction: 0.3, rim_fraction: 0.02, settle: {...}, resolution_span_us: 0,
//                resolution_settle_ms: 250, search_ends: true}
//     - alignment: {frames: 3}
//     - latency: {servo: Rx, amplitude_us: 40, trials: 5, max_frames: 20}
//     - saccade: {eye: right, axis: pan, amplitudes_deg: [10], trials: 3, frames: 20,
//                 locator: fixation, range_m: 1.0, tolerance_px: 1.0, max_corrections: 4,
//                 latency_frames: 0, shape: true, limit_margin_us: 20}
//                (the calibrated-map controller, protocols/saccade_step.h)
//     - vor: {sines_hz: [0.2, 0.5, 1.0], amplitude_deg: 10, cycles: 2, steps_deg: [10], hold_ms: 1000,
//             range_m: 1.0, max_neck_deg_per_s: 150, locator: fixation, limit_margin_us: 20}
//            (the vestibulo-ocular reflex on the calibrated maps, protocols/vor_step.h)
//     - track: {pan_deg: 6, tilt_deg: 3, frequency_hz: 0.5, cycles: 1, leave_deg: 0, leave_ms: 500,
//               return_ms: 700, salience_candidates: 3, gain: 0.3, limit_margin_us: 20}
//            (salience targets and the fixation and Lucas-Kanade trackers against truth,
//             protocols/track_step.h)
//     - wait: {ms: 500}
//     - repeat: {times: 2, steps: [ ...steps... ]}
//   Every step may also carry `name: text` (default "<kind><index>").
//
// Pulse-width values (pose entries, sweep from/to) are an integer [us] or an expression on
// the robot file's values of that servo: centre, min, max, centre+N, centre-N, min+N, max-N.
// Unlisted servos of a pose stay at the robot's centre. Grid offsets are "toward the robot's
// right / up" in us: the runner multiplies them by each servo's direction (so a tilt of +60
// raises both eyes although Ly is mirrored).
//
// detect: true detects the protocol's `target` (its geometry from `targets`) in both eyes of
// every recorded frame: observations.csv, and coverage.csv (X/Y/Size/Skew) at the end; the
// `tag_targets` go to observations.csv too (one target_id per grid), not into coverage.csv.
//
// settle: {mode: image|time, time_ms: 300, min_ms: 150, max_ms: 2000, still_px: 0.5,
//          still_frames: 2}. image = wait at least min_ms, then until the image moved less
// than still_px between still_frames consecutive frame pairs (or max_ms passed, reported).
//
// A loaded step is a Step: its name and place in the file, and a std::variant of one struct per
// kind (StepParams) holding that kind's fields, with enums for every choice.
//
// Parse errors throw ProtocolError naming the file, the line, the step index and the field, e.g.
// "servo_sweep.yaml:12: step 3 (sweep): field 'step_us': -5 must be > 0".
#include <array>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <variant>
#include <vector>

#include <Eigen/Core>

#include "calib/target.h"
#include "models/head_kinematics.h"
#include "models/robot_config.h"

namespace owlcal::protocols {

struct ProtocolError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Bounds that keep a plan finite and its arithmetic in range: a loaded protocol has at most
// kMaxPlanSteps steps after `repeat` expansion (and list fields at most that many entries);
// every integer field lies within +-kMaxPlanInt, and every pulse-width quantity (step_us,
// pan_us, tilt_us, neck_us, amplitude_us, coarse_us, fine_us, max_step_us, limit_margin_us)
// within +-kMaxPulseUs (the packet's four digits), so no sum of them overflows an int. Whether
// a plan fits the robot is checked against the robot file by CheckStepForRobot.
inline constexpr int64_t kMaxPlanSteps = 10000;
inline constexpr int kMaxPlanInt = 1000000;
inline constexpr int kMaxPulseUs = 9999;

// One pulse width relative to the robot file: base + offset_us.
struct PwmExpr {
  enum class Base { kAbsolute, kCentre, kMin, kMax };
  Base base = Base::kCentre;
  int offset_us = 0;  // the absolute value for kAbsolute

  int Resolve(const models::ServoConfig& servo) const;
  std::string ToString() const;
};
// Parses "1545", "centre", "center", "min", "max", "centre+40", "max-10"; nullopt if malformed.
std::optional<PwmExpr> ParsePwmExpr(const std::string& text);

// A full pose: one expression per servo (default centre).
struct PoseSpec {
  std::array<PwmExpr, models::kNumServos> servo{};
  models::PwmVector Resolve(const models::RobotConfig& robot) const;
};

struct SettleRule {
  enum class Mode { kImage, kTime };
  Mode mode = Mode::kImage;
  int time_ms = 300;      // kTime: fixed wait
  int min_ms = 150;       // kImage: never less (covers the stream latency)
  int max_ms = 2000;      // kImage: give up (reported in events.log)
  double still_px = 0.5;  // kImage: image shift counted as "not moving" [px]
  int still_frames = 2;   // kImage: consecutive still frame pairs needed
};

// The step kinds, in the order of the alternatives of StepParams.
enum class StepKind {
  kMoveTo,
  kSweep,
  kGrid,
  kPlaceTarget,
  kCapture,
  kFixate,
  kStepResponse,
  kLimits,
  kAlignment,
  kLatency,
  kWait,
  kSaccade,
  kVor,
  kMainSequence,
  kCatchUp,
  kTrack,
};
const char* StepKindName(StepKind kind);  // "move-to", "sweep", ...

// kLk: Lucas-Kanade tracking seeded by the fixation locator (protocols/fixation.h MakeLkLocator).
enum class Locator { kFixation, kTemplate, kAprilTag, kLk };
const char* LocatorName(Locator locator);  // "fixation", "template", "apriltag", "lk"

// Which eyes a grid moves or a fixation controls.
enum class EyeSet { kBoth, kLeft, kRight };
const char* EyeSetName(EyeSet eyes);  // "both", "left", "right"
bool Includes(EyeSet eyes, models::Eye eye);

// The axis a step response steps.
enum class Axis { kPan, kTilt };
const char* AxisName(Axis axis);  // "pan", "tilt"

// move-to: one pose, then `frames` recorded frames.
struct MoveToStep {
  PoseSpec pose;
  SettleRule settle;
  int frames = 0;
};

// sweep: one servo from `from` to `to` in step_us steps (and back), the others at `hold`.
struct SweepStep {
  int servo = 0;
  PwmExpr from{PwmExpr::Base::kMin, 0}, to{PwmExpr::Base::kMax, 0};
  int step_us = 20;
  bool both_directions = true;
  bool pre_approach = true;  // start one step before `from` so every point has a known approach
  PoseSpec hold;
  SettleRule settle;
  int frames = 1;
  bool detect = false;
  bool tags = true;  // with detect: also the protocol's tag_targets (false: the board only)
};

// grid: offsets in us toward the robot's right / up, relative to the hold pose.
struct GridStep {
  EyeSet eyes = EyeSet::kBoth;
  std::vector<int> pan_us{0}, tilt_us{0}, neck_us{0};
  PoseSpec hold;
  SettleRule settle;
  int frames = 1;
  bool detect = false;
};

struct PlaceTargetStep {
  std::string target;
  double distance_m = 0.6;
  Eigen::Vector2d offset_m = Eigen::Vector2d::Zero();  // x right, y down, of the target centre
  Eigen::Vector3d rpy_deg = Eigen::Vector3d::Zero();   // roll (about z), pitch (about x), yaw (about y)
  bool hide_others = true;
  std::string prompt;  // custom prompt text; default built from target and distance
};

struct CaptureStep {
  SettleRule settle;
  int frames = 1;
  bool detect = false;
};

// The closed loop's settings shared by fixate and step-response (protocols/fixation.h).
struct ClosedLoopSettings {
  Locator locator = Locator::kFixation;
  int max_iterations = 90;
  double tolerance_px = 0.5;
  int still_frames = 4;
  int latency_frames = 0;  // 0: update every frame (the course's loop); n: wait n frames per update
  int max_step_us = 60;
  int limit_margin_us = 20;
  bool record_frames = false;
};

struct FixateStep {
  ClosedLoopSettings loop;
  EyeSet eyes = EyeSet::kBoth;
  double gain = 0.1;
  bool from_centre = false;  // `from: centre`: start at the centre pose (default settle rule)
};

struct StepResponseStep {
  ClosedLoopSettings loop;  // loop.max_iterations = frames
  models::Eye eye = models::kRightEye;
  Axis axis = Axis::kPan;
  std::vector<double> amplitudes_deg{5, 10, 20};
  std::vector<double> gains{0.1};
  int frames = 45;
  int trials = 1;
};

struct LimitsStep {
  std::vector<int> servos{0, 1, 2, 3, 4};
  int coarse_us = 20;
  int fine_us = 2;
  int frames = 1;
  double moved_fraction = 0.3;
  double rim_fraction = 0.02;  // growth of the dark fraction of the border band (RimFraction)
  bool record_frames = true;
  SettleRule settle;
  // > 0: before its ends, each servo's PWM step and dead band are probed at the centre with a
  // fine sweep of this span (models::ResolutionSweepOffsets; resolution.csv, fitted by
  // fitting/servo_resolution_fit.h), watching the fixation target (it must be in view of both
  // eyes at the centre pose). 0: no probe.
  int resolution_span_us = 0;
  int resolution_settle_ms = 250;  // wait after each probe command
  bool search_ends = true;         // false: only the resolution probe (no limits.csv rows)
};

struct AlignmentStep {
  int frames = 3;
  SettleRule settle;
};

struct LatencyStep {
  int servo = 0;
  int amplitude_us = 40;
  int trials = 5;
  int max_frames = 20;
  bool record_frames = false;
  SettleRule settle;
};

struct WaitStep {
  int ms = 0;
};

// saccade: per amplitude and trial, fixate one eye's target with the calibrated-map controller,
// step the servo away by the amplitude (alternating direction, nominal scale as step-response),
// and bring it back with one saccade computed from the calibration's servo maps and the
// target's pixel, corrected by latency-aware steps (protocols/saccade_step.h).
struct SaccadeStep {
  models::Eye eye = models::kRightEye;
  Axis axis = Axis::kPan;
  std::vector<double> amplitudes_deg{10};
  int trials = 3;
  int frames = 20;  // frames logged per trial from the saccade's first frame
  Locator locator = Locator::kFixation;
  double range_m = 1.0;       // the target's assumed distance (the camera sits ahead of the eye's axis)
  double tolerance_px = 1.0;  // no correction when the target is this close to the centre
  int max_corrections = 4;    // corrective steps after the saccade, per trial
  int latency_frames = 0;     // frames from a command to the first frame that shows it; 0: from the
                              // calibration's measured delay, else 4
  bool shape = true;          // overdrive-and-switch command shaping from the fitted slew and lag
  int limit_margin_us = 20;
};

// vor: the vestibulo-ocular reflex (protocols/vor_step.h). Both eyes fixate the protocol's target
// with the calibrated maps; the neck then turns through each profile (a sine of amplitude_deg at
// each of sines_hz for `cycles` cycles; a step of each of steps_deg held hold_ms and back), once
// with the eyes held still and once with the eyes counter-rotating on the calibrated neck and
// eye-pan maps. Every frame is logged (vor.csv), every trial is a row with status (vor_trials.csv).
// Peak neck velocity 2 pi f A must stay within max_neck_deg_per_s (at most the guide's 300 deg/s).
struct VorStep {
  std::vector<double> sines_hz{0.2, 0.5, 1.0};
  double amplitude_deg = 10;
  double cycles = 2;
  std::vector<double> steps_deg{10};
  int hold_ms = 1000;
  double range_m = 1.0;  // the target's distance, for the maps (the camera sits ahead of the eye's axis)
  double max_neck_deg_per_s = 150;
  Locator locator = Locator::kFixation;
  int limit_margin_us = 20;
};

// main-sequence: the saccade main sequence (protocols/main_sequence_step.h). One eye fixates the
// protocol's target with the calibrated maps; then per amplitude and repeat its pan servo jumps
// from amplitude/2 on one side of the fixation to amplitude/2 on the other (alternating
// direction; the target stays in view), the command sent at a different phase of the frame
// clock each time, and every frame from the command on is logged (main_sequence.csv). A saccade
// whose ends would come within limit_margin_us of a limit is a skipped row, never sent.
struct MainSequenceStep {
  models::Eye eye = models::kRightEye;
  std::vector<double> amplitudes_deg{2, 5, 10, 20, 30, 40};
  int repeats = 4;
  int frames = 18;       // frames logged per saccade from the command (600 ms at 30 fps)
  int rest_ms = 400;     // at the saccade's start pose before the command
  double range_m = 1.0;  // the target's distance, for the maps (the camera sits ahead of the eye's axis)
  Locator locator = Locator::kFixation;
  int limit_margin_us = 20;
};

// catch-up: pursuit with catch-up saccades of a target moving at each of speeds_deg_per_s for
// duration_ms (protocols/catch_up_step.h; needs a robot that can move the target: the virtual Owl).
// The eye pursues with a P loop of pursuit_gain on the calibrated map and makes a catch-up saccade
// when the retinal error passes threshold_deg. Every frame is logged (catch_up.csv), every trial is
// a row with status (catch_up_trials.csv).
struct CatchUpStep {
  models::Eye eye = models::kRightEye;
  std::vector<double> speeds_deg_per_s{10, 20, 30};
  int duration_ms = 2000;      // the target moves for this long (centred on straight ahead), then holds
  int hold_ms = 500;           // frames logged after it stopped
  double threshold_deg = 3.0;  // retinal error that triggers a catch-up saccade
  double pursuit_gain = 0.15;  // fraction of the map's correction sent per frame while pursuing
  double range_m = 1.0;
  Locator locator = Locator::kFixation;
  int limit_margin_us = 20;
  // > 0: an induced loss: this long after each trial starts the target is turned behind the robot
  // (out of view), so that the step must say lost from the images alone (tests).
  int hide_after_ms = 0;
};

// track: salience targets and tracking (protocols/track_step.h). With salience_candidates > 0 a
// salience map of the right eye (calib/salience.h) picks that many candidates and the right eye
// fixates each from the start pose with the LK tracker seeded at the candidate (gain, the fixation
// loop). Then both eyes move through a figure of eight on the nominal servo scales (pan_deg sin(2
// pi f t), tilt_deg sin(4 pi f t), `cycles` cycles at frequency_hz) and, with leave_deg > 0, pan
// leave_deg to the robot's right for leave_ms (the target leaves the view) and back for return_ms;
// every frame the target is located in both eyes by the fixation locator and by LK.
struct TrackStep {
  double pan_deg = 6, tilt_deg = 3;
  double frequency_hz = 0.5;
  double cycles = 1;
  double leave_deg = 0;
  int leave_ms = 500, return_ms = 700;
  int salience_candidates = 3;
  double gain = 0.3;
  int limit_margin_us = 20;
};

// One alternative per StepKind, in its order: StepKind(params.index()) is the kind.
using StepParams = std::variant<MoveToStep,
                                SweepStep,
                                GridStep,
                                PlaceTargetStep,
                                CaptureStep,
                                FixateStep,
                                StepResponseStep,
                                LimitsStep,
                                AlignmentStep,
                                LatencyStep,
                                WaitStep,
                                SaccadeStep,
                                VorStep,
                                MainSequenceStep,
                                CatchUpStep,
                                TrackStep>;

// For std::visit on StepParams: Overloaded{[](const SweepStep& s) {...}, ...}.
template <typename... F>
struct Overloaded : F... {
  using F::operator()...;
};

struct Step {
  std::string name;
  std::string file;    // the protocol file it came from
  int file_index = 0;  // index in that file's (expanded) steps, for messages
  int file_line = 0;   // its line in the file (1-based; 0 = unknown), for messages
  StepParams params;

  StepKind kind() const { return static_cast<StepKind>(params.index()); }
  // The kind's fields; std::bad_variant_access when the step is of another kind.
  template <typename T>
  const T& As() const {
    return std::get<T>(params);
  }
  template <typename T>
  T& As() {
    return std::get<T>(params);
  }
  // True when the step's recorded frames are searched for the protocol's target (`detect`).
  bool Detects() const;
  // True when those frames are searched for the protocol's tag_targets too (a sweep's `tags`).
  bool DetectsTags() const;
  // "FILE:LINE: step INDEX (KIND)": where the step is, for messages.
  std::string Where() const;
};

struct Protocol {
  std::string name;
  std::string description;
  std::string file;  // path it was loaded from ("" for text)
  std::string text;  // the file's text (recorded in the manifest)
  std::string target;
  std::string target_description;
  std::map<std::string, calib::TargetDefinition> targets;
  std::vector<std::string> tag_targets;  // AprilGrids of `targets` fixed in the scene, detected too
  std::vector<Step> steps;
};

// Loads a protocol file; throws ProtocolError (naming file, step index and field).
Protocol LoadProtocolFile(const std::string& path);

// "" if the step's pulse-width quantities fit the robot file: step_us, amplitude_us,
// coarse_us and max_step_us no larger than the servo's range (max_us - min_us),
// limit_margin_us below half of it (grid offsets beyond the range are clamped and reported).
// Else why, naming the file, line, step and field
// ("wide.yaml:4: step 0 (sweep): field 'step_us': 5000 us is more than Rx's range of 1000 us").
// The runner and the dry-run plan refuse a protocol that does not fit, before anything moves.
std::string CheckStepForRobot(const Step& step, const models::RobotConfig& robot);
// Parses protocol YAML text; `source` names it in errors.
Protocol ParseProtocolYaml(const std::string& yaml_text, const std::string& source);
// The targets (`targets`) of every protocol a dataset's manifest recorded (its protocol texts),
// by name; throws naming the manifest when it or a protocol text cannot be read.
std::map<std::string, calib::TargetDefinition> TargetsOfDataset(const std::string& dataset);

// Resolves a protocol argument: an existing path, or the name of a standard protocol
// ("servo_sweep" -> <source dir>/protocols/standard/servo_sweep.yaml).
std::string ResolveProtocolPath(const std::string& name_or_path);
// The folder of the standard suite.
std::string StandardProtocolDir();
// Names of the standard protocols in the order of a full calibration run.
std::vector<std::string> StandardProtocolNames();

// Servo name ("Rx", case-insensitive) -> index; -1 if unknown.
int ServoIndexFromName(const std::string& name);

}  // namespace owlcal::protocols
