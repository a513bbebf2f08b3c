// Step parsing: the fields of each kind of step (protocols/protocol.h documents them), read by
// ParseStepParams (declared in protocols/protocol_fields.h) with the shared pieces (pose, settle
// rule, eyes, closed loop, locator).
#include <cmath>
#include <string>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "protocols/protocol_fields.h"

namespace owlcal::protocols::internal {
namespace {

PoseSpec ParsePose(const YAML::Node& node, const std::string& source, const std::string& where) {
  PoseSpec pose;
  if (!node) return pose;
  Fields f(node, source, where);
  for (int i = 0; i < models::kNumServos; ++i) {
    const std::string name = models::kServoNames[i];
    if (f.Has(name)) pose.servo[i] = f.Pwm(name, {});
  }
  f.RejectUnknown();
  return pose;
}

SettleRule ParseSettle(const YAML::Node& node, const std::string& source, const std::string& where) {
  const SettleRule def;
  if (!node) return def;
  Fields f(node, source, where);
  SettleRule s = def;
  s.mode = f.Enum("mode", def.mode, {{"image", SettleRule::Mode::kImage}, {"time", SettleRule::Mode::kTime}});
  s.time_ms = f.PositiveInt("time_ms", def.time_ms, 0);
  s.min_ms = f.PositiveInt("min_ms", def.min_ms, 0);
  s.max_ms = f.PositiveInt("max_ms", def.max_ms, 1);
  s.still_px = f.PositiveDouble("still_px", def.still_px);
  s.still_frames = f.PositiveInt("still_frames", def.still_frames);
  if (s.max_ms < s.min_ms) f.Fail("max_ms", std::to_string(s.max_ms) + " is below min_ms " + std::to_string(s.min_ms));
  f.RejectUnknown();
  return s;
}

// The step's `settle` map (defaults when it has none).
SettleRule ParseStepSettle(Fields& f, const std::string& source, const std::string& where) {
  return ParseSettle(f.Get("settle"), source, where + " settle");
}

Locator ParseLocator(Fields& f) {
  return f.Enum("locator",
                Locator::kFixation,
                {{"fixation", Locator::kFixation},
                 {"template", Locator::kTemplate},
                 {"apriltag", Locator::kAprilTag},
                 {"lk", Locator::kLk}});
}

models::Eye ParseEye(Fields& f) {
  return f.Enum("eye", models::kRightEye, {{"left", models::kLeftEye}, {"right", models::kRightEye}});
}

Axis ParseAxis(Fields& f) { return f.Enum("axis", Axis::kPan, {{"pan", Axis::kPan}, {"tilt", Axis::kTilt}}); }

EyeSet ParseEyeSet(Fields& f) {
  return f.Enum("eyes", EyeSet::kBoth, {{"both", EyeSet::kBoth}, {"left", EyeSet::kLeft}, {"right", EyeSet::kRight}});
}

ClosedLoopSettings ParseClosedLoop(Fields& f) {
  ClosedLoopSettings l;
  l.locator = ParseLocator(f);
  l.max_iterations = f.PositiveInt("max_iterations", l.max_iterations);
  l.tolerance_px = f.PositiveDouble("tolerance_px", l.tolerance_px);
  l.still_frames = f.PositiveInt("still_frames", l.still_frames);
  l.latency_frames = f.PositiveInt("latency_frames", 0, 0);
  l.max_step_us = f.PulseUs("max_step_us", l.max_step_us);
  l.limit_margin_us = f.PulseUs("limit_margin_us", l.limit_margin_us, 0);
  l.record_frames = f.Value<bool>("record_frames", false);
  return l;
}

// move-to
StepParams ParseMoveToStep(Fields& f, const std::string& source, const std::string& where) {
  MoveToStep s;
  s.pose = ParsePose(f.Get("pose"), source, where + " pose");
  s.settle = ParseStepSettle(f, source, where);
  s.frames = f.PositiveInt("frames", 0, 0);
  return s;
}

// sweep
StepParams ParseSweepStep(Fields& f, const std::string& source, const std::string& where) {
  SweepStep s;
  s.servo = f.Servo("servo");
  s.from = f.Pwm("from", s.from);
  s.to = f.Pwm("to", s.to);
  s.step_us = f.PulseUs("step_us", s.step_us);
  s.both_directions = f.Value<bool>("both_directions", true);
  s.pre_approach = f.Value<bool>("pre_approach", true);
  s.detect = f.Value<bool>("detect", false);
  s.tags = f.Value<bool>("tags", true);
  s.frames = f.PositiveInt("frames", 1);
  s.hold = ParsePose(f.Get("hold"), source, where + " hold");
  s.settle = ParseStepSettle(f, source, where);
  return s;
}

// grid
StepParams ParseGridStep(Fields& f, const std::string& source, const std::string& where) {
  GridStep s;
  s.eyes = ParseEyeSet(f);
  s.pan_us = f.PulseOffsets("pan_us", {0});
  s.tilt_us = f.PulseOffsets("tilt_us", {0});
  s.neck_us = f.PulseOffsets("neck_us", {0});
  s.frames = f.PositiveInt("frames", 1);
  s.hold = ParsePose(f.Get("hold"), source, where + " hold");
  s.settle = ParseStepSettle(f, source, where);
  s.detect = f.Value<bool>("detect", false);
  return s;
}

// place-target
StepParams ParsePlaceTargetStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  PlaceTargetStep s;
  s.target = f.Scalar("target");
  s.distance_m = f.PositiveDouble("distance_m", 0.6);
  const auto off = f.List<double>("offset_m", {0, 0});
  if (off.size() != 2) f.Fail("offset_m", "expected [x, y]");
  s.offset_m = Eigen::Vector2d(off[0], off[1]);
  const auto rpy = f.List<double>("rpy_deg", {0, 0, 0});
  if (rpy.size() != 3) f.Fail("rpy_deg", "expected [roll, pitch, yaw]");
  s.rpy_deg = Eigen::Vector3d(rpy[0], rpy[1], rpy[2]);
  s.hide_others = f.Value<bool>("hide_others", true);
  s.prompt = f.Value<std::string>("prompt", "");
  return s;
}

// capture
StepParams ParseCaptureStep(Fields& f, const std::string& source, const std::string& where) {
  CaptureStep s;
  s.frames = f.PositiveInt("frames", 1);
  s.settle = ParseStepSettle(f, source, where);
  s.detect = f.Value<bool>("detect", false);
  return s;
}

// fixate
StepParams ParseFixateStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  FixateStep s;
  s.loop = ParseClosedLoop(f);
  s.eyes = ParseEyeSet(f);
  s.gain = f.PositiveDouble("gain", 0.1);
  s.from_centre = f.Enum("from", false, {{"current", false}, {"centre", true}});
  return s;
}

// step-response
StepParams ParseStepResponseStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  StepResponseStep s;
  s.loop = ParseClosedLoop(f);
  s.eye = ParseEye(f);
  s.axis = ParseAxis(f);
  s.amplitudes_deg = f.List<double>("amplitudes_deg", s.amplitudes_deg);
  s.gains = f.List<double>("gains", s.gains);
  for (double g : s.gains)
    if (!(g > 0)) f.Fail("gains", std::to_string(g) + " must be > 0");
  for (double a : s.amplitudes_deg)
    if (!(a > 0 && a <= 45)) f.Fail("amplitudes_deg", std::to_string(a) + " must be in (0, 45]");
  s.frames = f.PositiveInt("frames", 45, 2);
  s.trials = f.PositiveInt("trials", 1);
  s.loop.max_iterations = s.frames;
  return s;
}

// limits
StepParams ParseLimitsStep(Fields& f, const std::string& source, const std::string& where) {
  LimitsStep s;
  if (f.Has("servos")) {
    s.servos.clear();
    for (const std::string& n : f.List<std::string>("servos", {})) {
      const int i = ServoIndexFromName(n);
      if (i < 0) f.Fail("servos", "'" + n + "' is not a servo (Rx, Ry, Lx, Ly, Neck)");
      s.servos.push_back(i);
    }
  }
  s.coarse_us = f.PulseUs("coarse_us", s.coarse_us);
  s.fine_us = f.PulseUs("fine_us", s.fine_us);
  if (s.fine_us > s.coarse_us) f.Fail("fine_us", std::to_string(s.fine_us) + " is larger than coarse_us");
  s.frames = f.PositiveInt("frames", 1);
  s.moved_fraction = f.PositiveDouble("moved_fraction", s.moved_fraction);
  s.rim_fraction = f.PositiveDouble("rim_fraction", s.rim_fraction);
  s.record_frames = f.Value<bool>("record_frames", true);
  s.settle = ParseStepSettle(f, source, where);
  s.resolution_span_us = f.PositiveInt("resolution_span_us", 0, 0);
  if (s.resolution_span_us != 0 && (s.resolution_span_us < 6 || s.resolution_span_us > 60))
    f.Fail("resolution_span_us", std::to_string(s.resolution_span_us) + " must be 0 (no probe) or in [6, 60]");
  s.resolution_settle_ms = f.PositiveInt("resolution_settle_ms", s.resolution_settle_ms, 1);
  s.search_ends = f.Value<bool>("search_ends", true);
  if (!s.search_ends && s.resolution_span_us == 0)
    f.Fail("search_ends", "false with resolution_span_us 0: the step would measure nothing");
  return s;
}

// alignment
StepParams ParseAlignmentStep(Fields& f, const std::string& source, const std::string& where) {
  AlignmentStep s;
  s.frames = f.PositiveInt("frames", 3);
  s.settle = ParseStepSettle(f, source, where);
  return s;
}

// latency
StepParams ParseLatencyStep(Fields& f, const std::string& source, const std::string& where) {
  LatencyStep s;
  s.servo = f.Servo("servo");
  s.amplitude_us = f.PulseUs("amplitude_us", s.amplitude_us);
  s.trials = f.PositiveInt("trials", 5);
  s.max_frames = f.PositiveInt("max_frames", s.max_frames);
  s.record_frames = f.Value<bool>("record_frames", false);
  s.settle = ParseStepSettle(f, source, where);
  return s;
}

// wait
StepParams ParseWaitStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  WaitStep s;
  s.ms = f.PositiveInt("ms", 0, 0);
  return s;
}

// saccade
StepParams ParseSaccadeStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  SaccadeStep s;
  s.eye = ParseEye(f);
  s.axis = ParseAxis(f);
  s.amplitudes_deg = f.List<double>("amplitudes_deg", s.amplitudes_deg);
  for (double a : s.amplitudes_deg)
    if (!(a > 0 && a <= 45)) f.Fail("amplitudes_deg", std::to_string(a) + " must be in (0, 45]");
  s.trials = f.PositiveInt("trials", s.trials);
  s.frames = f.PositiveInt("frames", s.frames, 2);
  s.locator = ParseLocator(f);
  s.range_m = f.PositiveDouble("range_m", s.range_m);
  s.tolerance_px = f.PositiveDouble("tolerance_px", s.tolerance_px);
  s.max_corrections = f.PositiveInt("max_corrections", s.max_corrections, 0);
  s.latency_frames = f.PositiveInt("latency_frames", 0, 0);
  s.shape = f.Value<bool>("shape", true);
  s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
  return s;
}

// vor
StepParams ParseVorStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  VorStep s;
  // An empty list ([]) leaves that kind of profile out.
  auto none = [&](const char* key) {
    return f.Has(key) && f.Get(key).IsSequence() && f.Get(key).size() == 0;  // Get marks it used
  };
  const bool no_sines = none("sines_hz"), no_steps = none("steps_deg");
  s.sines_hz = no_sines ? std::vector<double>{} : f.List<double>("sines_hz", s.sines_hz);
  for (double hz : s.sines_hz)
    if (!(hz >= 0.05 && hz <= 2)) f.Fail("sines_hz", std::to_string(hz) + " must be in [0.05, 2]");
  s.amplitude_deg = f.PositiveDouble("amplitude_deg", s.amplitude_deg);
  if (s.amplitude_deg > 30) f.Fail("amplitude_deg", std::to_string(s.amplitude_deg) + " must be in (0, 30]");
  s.cycles = f.PositiveDouble("cycles", s.cycles);
  if (s.cycles < 1 || s.cycles > 20) f.Fail("cycles", std::to_string(s.cycles) + " must be in [1, 20]");
  s.steps_deg = no_steps ? std::vector<double>{} : f.List<double>("steps_deg", s.steps_deg);
  for (double a : s.steps_deg)
    if (!(a > 0 && a <= 30)) f.Fail("steps_deg", std::to_string(a) + " must be in (0, 30]");
  if (s.sines_hz.empty() && s.steps_deg.empty()) f.Fail("sines_hz", "no sine and no step (steps_deg): nothing to run");
  s.hold_ms = f.PositiveInt("hold_ms", s.hold_ms, 200);
  s.range_m = f.PositiveDouble("range_m", s.range_m);
  s.max_neck_deg_per_s = f.PositiveDouble("max_neck_deg_per_s", s.max_neck_deg_per_s);
  if (s.max_neck_deg_per_s > 300)
    f.Fail("max_neck_deg_per_s",
           std::to_string(s.max_neck_deg_per_s) + " is above the servos' 300 deg/s slew at 4.8 V (the guide)");
  for (double hz : s.sines_hz)
    if (2 * M_PI * hz * s.amplitude_deg > s.max_neck_deg_per_s)
      f.Fail("sines_hz",
             std::to_string(hz) + " Hz at " + std::to_string(s.amplitude_deg) + " deg peaks at " +
                 std::to_string(2 * M_PI * hz * s.amplitude_deg) + " deg/s, above max_neck_deg_per_s " +
                 std::to_string(s.max_neck_deg_per_s));
  s.locator = ParseLocator(f);
  s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
  return s;
}

// track
StepParams ParseTrackStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  TrackStep s;
  s.pan_deg = f.PositiveDouble("pan_deg", s.pan_deg, true);
  s.tilt_deg = f.PositiveDouble("tilt_deg", s.tilt_deg, true);
  if (s.pan_deg > 20 || s.tilt_deg > 20) f.Fail("pan_deg", "pan_deg and tilt_deg must be in [0, 20]");
  s.frequency_hz = f.PositiveDouble("frequency_hz", s.frequency_hz);
  if (s.frequency_hz > 2) f.Fail("frequency_hz", std::to_string(s.frequency_hz) + " must be in (0, 2]");
  s.cycles = f.PositiveDouble("cycles", s.cycles);
  if (s.cycles > 20) f.Fail("cycles", std::to_string(s.cycles) + " must be in (0, 20]");
  s.leave_deg = f.PositiveDouble("leave_deg", s.leave_deg, true);
  if (s.leave_deg > 40) f.Fail("leave_deg", std::to_string(s.leave_deg) + " must be in [0, 40]");
  s.leave_ms = f.PositiveInt("leave_ms", s.leave_ms, 100);
  s.return_ms = f.PositiveInt("return_ms", s.return_ms, 100);
  s.salience_candidates = f.PositiveInt("salience_candidates", s.salience_candidates, 0);
  if (s.salience_candidates > 10) f.Fail("salience_candidates", "at most 10");
  s.gain = f.PositiveDouble("gain", s.gain);
  if (s.gain >= 1) f.Fail("gain", std::to_string(s.gain) + " must be in (0, 1)");
  s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
  return s;
}

// main-sequence
StepParams ParseMainSequenceStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  MainSequenceStep s;
  s.eye = ParseEye(f);
  s.amplitudes_deg = f.List<double>("amplitudes_deg", s.amplitudes_deg);
  for (double a : s.amplitudes_deg)
    if (!(a >= 0.5 && a <= 45)) f.Fail("amplitudes_deg", std::to_string(a) + " must be in [0.5, 45]");
  s.repeats = f.PositiveInt("repeats", s.repeats);
  s.frames = f.PositiveInt("frames", s.frames, 6);
  s.rest_ms = f.PositiveInt("rest_ms", s.rest_ms, 100);
  s.range_m = f.PositiveDouble("range_m", s.range_m);
  s.locator = ParseLocator(f);
  s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
  return s;
}

// catch-up
StepParams ParseCatchUpStep(Fields& f, const std::string& /*source*/, const std::string& /*where*/) {
  CatchUpStep s;
  s.eye = ParseEye(f);
  s.speeds_deg_per_s = f.List<double>("speeds_deg_per_s", s.speeds_deg_per_s);
  s.duration_ms = f.PositiveInt("duration_ms", s.duration_ms, 200);
  for (double v : s.speeds_deg_per_s) {
    if (!(v > 0 && v <= 60)) f.Fail("speeds_deg_per_s", std::to_string(v) + " must be in (0, 60]");
    if (v * s.duration_ms / 1000.0 > 70)
      f.Fail("speeds_deg_per_s",
             std::to_string(v) + " deg/s for " + std::to_string(s.duration_ms) +
                 " ms sweeps more than 70 deg (the eye's pan range)");
  }
  s.hold_ms = f.PositiveInt("hold_ms", s.hold_ms, 0);
  s.threshold_deg = f.PositiveDouble("threshold_deg", s.threshold_deg);
  s.pursuit_gain = f.PositiveDouble("pursuit_gain", s.pursuit_gain);
  if (s.pursuit_gain > 1) f.Fail("pursuit_gain", std::to_string(s.pursuit_gain) + " must be in (0, 1]");
  s.range_m = f.PositiveDouble("range_m", s.range_m);
  s.locator = ParseLocator(f);
  s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
  s.hide_after_ms = f.PositiveInt("hide_after_ms", s.hide_after_ms, 0);
  return s;
}

}  // namespace

StepParams ParseStepParams(const std::string& kind, Fields& f, const std::string& source, const std::string& where) {
  using Parser = StepParams (*)(Fields&, const std::string&, const std::string&);
  static const std::pair<const char*, Parser> kParsers[] = {
      {"move-to", ParseMoveToStep},
      {"sweep", ParseSweepStep},
      {"grid", ParseGridStep},
      {"place-target", ParsePlaceTargetStep},
      {"capture", ParseCaptureStep},
      {"fixate", ParseFixateStep},
      {"step-response", ParseStepResponseStep},
      {"limits", ParseLimitsStep},
      {"alignment", ParseAlignmentStep},
      {"latency", ParseLatencyStep},
      {"wait", ParseWaitStep},
      {"saccade", ParseSaccadeStep},
      {"vor", ParseVorStep},
      {"track", ParseTrackStep},
      {"main-sequence", ParseMainSequenceStep},
      {"catch-up", ParseCatchUpStep},
  };
  for (const auto& [name, parse] : kParsers)
    if (kind == name) return parse(f, source, where);
  throw ProtocolError(f.At(YAML::Node(YAML::NodeType::Undefined)) + "unknown step kind '" + kind +
                      "' (move-to, sweep, grid, place-target, capture, fixate, step-response, limits, "
                      "alignment, latency, wait, saccade, vor, main-sequence, catch-up, track, repeat)");
}

}  // namespace owlcal::protocols::internal
