#include "protocols/protocol.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

#include "io/strict_number.h"
#include "models/head_model.h"
#include "protocols/dataset.h"

#include "owlcal_version.h"

namespace owlcal::protocols {
namespace fs = std::filesystem;

int PwmExpr::Resolve(const models::ServoConfig& servo) const {
  switch (base) {
    case Base::kAbsolute:
      return offset_us;
    case Base::kCentre:
      return servo.centre_us + offset_us;
    case Base::kMin:
      return servo.min_us + offset_us;
    case Base::kMax:
      return servo.max_us + offset_us;
  }
  return servo.centre_us;
}

std::string PwmExpr::ToString() const {
  if (base == Base::kAbsolute) return std::to_string(offset_us);
  const char* b = base == Base::kCentre ? "centre" : base == Base::kMin ? "min" : "max";
  if (offset_us == 0) return b;
  std::string out = b;
  if (offset_us > 0) out.push_back('+');
  out.append(std::to_string(offset_us));
  return out;
}

std::optional<PwmExpr> ParsePwmExpr(const std::string& text_in) {
  std::string text;
  for (char c : text_in)
    if (!std::isspace(static_cast<unsigned char>(c))) text.push_back(static_cast<char>(std::tolower(c)));
  if (text.empty()) return std::nullopt;
  auto parse_int = [](const std::string& s) -> std::optional<int> {
    if (s.empty() || s.size() > 6) return std::nullopt;
    size_t i = (s[0] == '+' || s[0] == '-') ? 1 : 0;
    if (i == s.size()) return std::nullopt;
    for (size_t k = i; k < s.size(); ++k)
      if (!std::isdigit(static_cast<unsigned char>(s[k]))) return std::nullopt;
    return std::stoi(s);
  };
  PwmExpr e;
  static const std::pair<const char*, PwmExpr::Base> kBases[] = {{"centre", PwmExpr::Base::kCentre},
                                                                 {"center", PwmExpr::Base::kCentre},
                                                                 {"min", PwmExpr::Base::kMin},
                                                                 {"max", PwmExpr::Base::kMax}};
  for (const auto& [name, base] : kBases) {
    const std::string n = name;
    if (text.rfind(n, 0) == 0) {
      e.base = base;
      const std::string rest = text.substr(n.size());
      if (rest.empty()) return e;
      if (rest[0] != '+' && rest[0] != '-') return std::nullopt;
      const auto v = parse_int(rest);
      if (!v) return std::nullopt;
      e.offset_us = *v;
      return e;
    }
  }
  const auto v = parse_int(text);
  if (!v || *v < 0) return std::nullopt;
  e.base = PwmExpr::Base::kAbsolute;
  e.offset_us = *v;
  return e;
}

models::PwmVector PoseSpec::Resolve(const models::RobotConfig& robot) const {
  models::PwmVector p{};
  for (int i = 0; i < models::kNumServos; ++i) p[i] = servo[i].Resolve(robot.servos[i]);
  return p;
}

const char* StepKindName(StepKind kind) {
  switch (kind) {
    case StepKind::kMoveTo:
      return "move-to";
    case StepKind::kSweep:
      return "sweep";
    case StepKind::kGrid:
      return "grid";
    case StepKind::kPlaceTarget:
      return "place-target";
    case StepKind::kCapture:
      return "capture";
    case StepKind::kFixate:
      return "fixate";
    case StepKind::kStepResponse:
      return "step-response";
    case StepKind::kLimits:
      return "limits";
    case StepKind::kAlignment:
      return "alignment";
    case StepKind::kLatency:
      return "latency";
    case StepKind::kWait:
      return "wait";
    case StepKind::kSaccade:
      return "saccade";
    case StepKind::kVor:
      return "vor";
    case StepKind::kMainSequence:
      return "main-sequence";
    case StepKind::kCatchUp:
      return "catch-up";
    case StepKind::kTrack:
      return "track";
  }
  return "?";
}

const char* LocatorName(Locator locator) {
  switch (locator) {
    case Locator::kFixation:
      return "fixation";
    case Locator::kTemplate:
      return "template";
    case Locator::kAprilTag:
      return "apriltag";
    case Locator::kLk:
      return "lk";
  }
  return "?";
}

// StepKind(params.index()) is the kind: the alternatives follow the enum.
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kMoveTo), StepParams>, MoveToStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kSweep), StepParams>, SweepStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kGrid), StepParams>, GridStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kPlaceTarget), StepParams>, PlaceTargetStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kCapture), StepParams>, CaptureStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kFixate), StepParams>, FixateStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kStepResponse), StepParams>, StepResponseStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kLimits), StepParams>, LimitsStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kAlignment), StepParams>, AlignmentStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kLatency), StepParams>, LatencyStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kWait), StepParams>, WaitStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kSaccade), StepParams>, SaccadeStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kVor), StepParams>, VorStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kMainSequence), StepParams>, MainSequenceStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kCatchUp), StepParams>, CatchUpStep>);
static_assert(std::is_same_v<std::variant_alternative_t<int(StepKind::kTrack), StepParams>, TrackStep>);
static_assert(std::variant_size_v<StepParams> == int(StepKind::kTrack) + 1);

const char* EyeSetName(EyeSet eyes) {
  switch (eyes) {
    case EyeSet::kBoth:
      return "both";
    case EyeSet::kLeft:
      return "left";
    case EyeSet::kRight:
      return "right";
  }
  return "?";
}

bool Includes(EyeSet eyes, models::Eye eye) {
  return eyes == EyeSet::kBoth || (eyes == EyeSet::kLeft) == (eye == models::kLeftEye);
}

const char* AxisName(Axis axis) { return axis == Axis::kPan ? "pan" : "tilt"; }

bool Step::Detects() const {
  if (const auto* s = std::get_if<SweepStep>(&params)) return s->detect;
  if (const auto* s = std::get_if<GridStep>(&params)) return s->detect;
  if (const auto* s = std::get_if<CaptureStep>(&params)) return s->detect;
  return false;
}

bool Step::DetectsTags() const {
  if (const auto* s = std::get_if<SweepStep>(&params)) return s->detect && s->tags;
  return Detects();
}

std::string Step::Where() const {
  return file + (file_line > 0 ? ":" + std::to_string(file_line) : std::string()) + ": step " +
         std::to_string(file_index) + " (" + StepKindName(kind()) + ")";
}

int ServoIndexFromName(const std::string& name) {
  for (int i = 0; i < models::kNumServos; ++i) {
    std::string a = name, b = models::kServoNames[i];
    std::transform(a.begin(), a.end(), a.begin(), ::tolower);
    std::transform(b.begin(), b.end(), b.begin(), ::tolower);
    if (a == b) return i;
  }
  return -1;
}

namespace {

// Reads fields of one YAML map, naming the context in every error and rejecting unknown keys.
class Fields {
 public:
  // Messages read "SOURCE:LINE: WHERE: field 'KEY': ..." (LINE of the field, else of the map).
  // fallback_line (0-based) stands for a node without a position (an empty step body).
  Fields(const YAML::Node& node, std::string source, std::string where, int fallback_line = -1)
      : node_(node), source_(std::move(source)), where_(std::move(where)), fallback_line_(fallback_line) {
    if (!node_.IsMap()) throw ProtocolError(At(node_) + "expected a map of fields");
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& what) const {
    const YAML::Node n = node_[key];
    throw ProtocolError(At(n ? n : node_) + "field '" + key + "': " + what);
  }
  // "SOURCE:LINE: WHERE: " for a node of this map.
  std::string At(const YAML::Node& n) const {
    const int line = n.IsDefined() && n.Mark().line >= 0 ? n.Mark().line : fallback_line_;
    return source_ + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": " + where_ +
           (where_.empty() ? "" : ": ");
  }
  bool Has(const std::string& key) const { return static_cast<bool>(node_[key]); }
  YAML::Node Get(const std::string& key) {
    used_.insert(key);
    return node_[key];
  }
  std::string Scalar(const std::string& key) {
    YAML::Node n = Get(key);
    if (!n.IsScalar()) Fail(key, "expected a single value");
    return n.Scalar();
  }
  template <typename T>
  T Value(const std::string& key, T def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    YAML::Node n = Get(key);
    std::string why;
    const std::optional<T> v = Convert<T>(n, &why);
    if (!v) Fail(key, why);
    return *v;
  }
  // A scalar as T: ints and doubles strictly (io/strict_number.h: no hex, nan, inf, overflow).
  template <typename T>
  static std::optional<T> Convert(const YAML::Node& n, std::string* why) {
    if (!n.IsScalar()) {
      *why = "expected a single value, not a list or map";
      return std::nullopt;
    }
    if constexpr (std::is_same_v<T, int>) {
      int v = 0;
      *why = io::CheckInt(n.Scalar(), -kMaxPlanInt, kMaxPlanInt, &v);
      if (!why->empty()) return std::nullopt;
      return v;
    } else if constexpr (std::is_same_v<T, double>) {
      double v = 0;
      *why = io::CheckNumber(n.Scalar(), -1e9, 1e9, &v);
      if (!why->empty()) return std::nullopt;
      return v;
    } else {
      try {
        return n.as<T>();
      } catch (const YAML::Exception&) {
        *why = "'" + io::Printable(n.Scalar()) + "' has the wrong type";
        return std::nullopt;
      }
    }
  }
  int PositiveInt(const std::string& key, int def, int min_value = 1) {
    const int v = Value<int>(key, def);
    if (v < min_value) Fail(key, std::to_string(v) + " must be >= " + std::to_string(min_value));
    return v;
  }
  // A pulse-width quantity [us]: min_value .. kMaxPulseUs.
  int PulseUs(const std::string& key, int def, int min_value = 1) {
    const int v = PositiveInt(key, def, min_value);
    if (v > kMaxPulseUs) Fail(key, std::to_string(v) + " us is more than " + std::to_string(kMaxPulseUs) + " us");
    return v;
  }
  // A list of pulse-width offsets [us], each within +-kMaxPulseUs.
  std::vector<int> PulseOffsets(const std::string& key, std::vector<int> def) {
    std::vector<int> v = List<int>(key, std::move(def));
    for (int x : v)
      if (x < -kMaxPulseUs || x > kMaxPulseUs)
        Fail(key, std::to_string(x) + " us is outside +-" + std::to_string(kMaxPulseUs) + " us");
    return v;
  }
  double PositiveDouble(const std::string& key, double def, bool allow_zero = false) {
    const double v = Value<double>(key, def);
    if (!(allow_zero ? v >= 0 : v > 0)) Fail(key, std::to_string(v) + (allow_zero ? " must be >= 0" : " must be > 0"));
    return v;
  }
  template <typename T>
  std::vector<T> List(const std::string& key, std::vector<T> def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    YAML::Node n = Get(key);
    if (!n.IsSequence() || n.size() == 0) Fail(key, "expected a non-empty list");
    std::vector<T> out;
    if (n.size() > static_cast<size_t>(kMaxPlanSteps))
      Fail(key, "more than " + std::to_string(kMaxPlanSteps) + " entries");
    for (size_t i = 0; i < n.size(); ++i) {
      std::string why;
      const std::optional<T> v = Convert<T>(n[i], &why);
      if (!v) Fail(key, "entry " + std::to_string(i) + " " + why);
      out.push_back(*v);
    }
    return out;
  }
  PwmExpr Pwm(const std::string& key, PwmExpr def) {
    if (!Has(key)) {
      used_.insert(key);
      return def;
    }
    const std::string s = Scalar(key);
    auto e = ParsePwmExpr(s);
    if (!e) Fail(key, "'" + s + "' is not a pulse width (e.g. 1545, centre, centre+40, min+10, max-10)");
    return *e;
  }
  int Servo(const std::string& key) {
    const std::string s = Scalar(key);
    const int i = ServoIndexFromName(s);
    if (i < 0) Fail(key, "'" + s + "' is not a servo (Rx, Ry, Lx, Ly, Neck)");
    return i;
  }
  void RejectUnknown() const {
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (!used_.count(k)) throw ProtocolError(At(kv.first) + "unknown field '" + k + "'");
    }
  }
  // An enum from one of its names.
  template <typename E>
  E Enum(const std::string& key, E def, std::initializer_list<std::pair<const char*, E>> names) {
    const char* def_name = "";
    for (const auto& [name, value] : names)
      if (value == def) def_name = name;
    const std::string v = Value<std::string>(key, def_name);
    std::string list;
    for (const auto& [name, value] : names) {
      if (v == name) return value;
      list += std::string(list.empty() ? "" : ", ") + name;
    }
    Fail(key, "'" + v + "' is not one of " + list);
  }

 private:
  YAML::Node node_;
  std::string source_, where_;
  int fallback_line_ = -1;
  std::set<std::string> used_;
};

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

calib::TargetDefinition ParseTarget(const YAML::Node& node, const std::string& name, const std::string& source) {
  Fields f(node, source, "targets." + name);
  calib::TargetDefinition t;
  t.id = name;
  t.kind = f.Enum("target_type",
                  calib::TargetKind::kChessboard,
                  {{"chessboard", calib::TargetKind::kChessboard},
                   {"aprilgrid", calib::TargetKind::kAprilGrid},
                   {"fixation", calib::TargetKind::kFixation}});
  if (t.kind == calib::TargetKind::kChessboard) {
    t.cols = f.PositiveInt("cols", t.cols, 2);
    t.rows = f.PositiveInt("rows", t.rows, 2);
    t.square_m = f.PositiveDouble("square_size_m", t.square_m);
  } else if (t.kind == calib::TargetKind::kAprilGrid) {
    t.tag_cols = f.PositiveInt("tagCols", t.tag_cols);
    t.tag_rows = f.PositiveInt("tagRows", t.tag_rows);
    t.tag_size_m = f.PositiveDouble("tagSize", t.tag_size_m);
    t.tag_spacing = f.PositiveDouble("tagSpacing", t.tag_spacing, true);
    t.first_id = f.PositiveInt("first_id", t.first_id, 0);
    t.family = f.Value<std::string>("family", t.family);
  } else {
    t.fixation_radius_m = f.PositiveDouble("fixation_radius_m", t.fixation_radius_m);
  }
  f.RejectUnknown();
  return t;
}

EyeSet ParseEyeSet(Fields& f) {
  return f.Enum("eyes", EyeSet::kBoth, {{"both", EyeSet::kBoth}, {"left", EyeSet::kLeft}, {"right", EyeSet::kRight}});
}

ClosedLoopSettings ParseClosedLoop(Fields& f) {
  ClosedLoopSettings l;
  l.locator = f.Enum("locator",
                     Locator::kFixation,
                     {{"fixation", Locator::kFixation},
                      {"template", Locator::kTemplate},
                      {"apriltag", Locator::kAprilTag},
                      {"lk", Locator::kLk}});
  l.max_iterations = f.PositiveInt("max_iterations", l.max_iterations);
  l.tolerance_px = f.PositiveDouble("tolerance_px", l.tolerance_px);
  l.still_frames = f.PositiveInt("still_frames", l.still_frames);
  l.latency_frames = f.PositiveInt("latency_frames", 0, 0);
  l.max_step_us = f.PulseUs("max_step_us", l.max_step_us);
  l.limit_margin_us = f.PulseUs("limit_margin_us", l.limit_margin_us, 0);
  l.record_frames = f.Value<bool>("record_frames", false);
  return l;
}

// The fields of one step of kind `kind` (`where` names it in errors).
StepParams ParseStepParams(const std::string& kind, Fields& f, const std::string& source, const std::string& where) {
  auto settle = [&] { return ParseSettle(f.Get("settle"), source, where + " settle"); };
  if (kind == "move-to") {
    MoveToStep s;
    s.pose = ParsePose(f.Get("pose"), source, where + " pose");
    s.settle = settle();
    s.frames = f.PositiveInt("frames", 0, 0);
    return s;
  }
  if (kind == "sweep") {
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
    s.settle = settle();
    return s;
  }
  if (kind == "grid") {
    GridStep s;
    s.eyes = ParseEyeSet(f);
    s.pan_us = f.PulseOffsets("pan_us", {0});
    s.tilt_us = f.PulseOffsets("tilt_us", {0});
    s.neck_us = f.PulseOffsets("neck_us", {0});
    s.frames = f.PositiveInt("frames", 1);
    s.hold = ParsePose(f.Get("hold"), source, where + " hold");
    s.settle = settle();
    s.detect = f.Value<bool>("detect", false);
    return s;
  }
  if (kind == "place-target") {
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
  if (kind == "capture") {
    CaptureStep s;
    s.frames = f.PositiveInt("frames", 1);
    s.settle = settle();
    s.detect = f.Value<bool>("detect", false);
    return s;
  }
  if (kind == "fixate") {
    FixateStep s;
    s.loop = ParseClosedLoop(f);
    s.eyes = ParseEyeSet(f);
    s.gain = f.PositiveDouble("gain", 0.1);
    s.from_centre = f.Enum("from", false, {{"current", false}, {"centre", true}});
    return s;
  }
  if (kind == "step-response") {
    StepResponseStep s;
    s.loop = ParseClosedLoop(f);
    s.eye = f.Enum("eye", models::kRightEye, {{"left", models::kLeftEye}, {"right", models::kRightEye}});
    s.axis = f.Enum("axis", Axis::kPan, {{"pan", Axis::kPan}, {"tilt", Axis::kTilt}});
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
  if (kind == "limits") {
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
    s.settle = settle();
    s.resolution_span_us = f.PositiveInt("resolution_span_us", 0, 0);
    if (s.resolution_span_us != 0 && (s.resolution_span_us < 6 || s.resolution_span_us > 60))
      f.Fail("resolution_span_us", std::to_string(s.resolution_span_us) + " must be 0 (no probe) or in [6, 60]");
    s.resolution_settle_ms = f.PositiveInt("resolution_settle_ms", s.resolution_settle_ms, 1);
    s.search_ends = f.Value<bool>("search_ends", true);
    if (!s.search_ends && s.resolution_span_us == 0)
      f.Fail("search_ends", "false with resolution_span_us 0: the step would measure nothing");
    return s;
  }
  if (kind == "alignment") {
    AlignmentStep s;
    s.frames = f.PositiveInt("frames", 3);
    s.settle = settle();
    return s;
  }
  if (kind == "latency") {
    LatencyStep s;
    s.servo = f.Servo("servo");
    s.amplitude_us = f.PulseUs("amplitude_us", s.amplitude_us);
    s.trials = f.PositiveInt("trials", 5);
    s.max_frames = f.PositiveInt("max_frames", s.max_frames);
    s.record_frames = f.Value<bool>("record_frames", false);
    s.settle = settle();
    return s;
  }
  if (kind == "wait") {
    WaitStep s;
    s.ms = f.PositiveInt("ms", 0, 0);
    return s;
  }
  if (kind == "saccade") {
    SaccadeStep s;
    s.eye = f.Enum("eye", models::kRightEye, {{"left", models::kLeftEye}, {"right", models::kRightEye}});
    s.axis = f.Enum("axis", Axis::kPan, {{"pan", Axis::kPan}, {"tilt", Axis::kTilt}});
    s.amplitudes_deg = f.List<double>("amplitudes_deg", s.amplitudes_deg);
    for (double a : s.amplitudes_deg)
      if (!(a > 0 && a <= 45)) f.Fail("amplitudes_deg", std::to_string(a) + " must be in (0, 45]");
    s.trials = f.PositiveInt("trials", s.trials);
    s.frames = f.PositiveInt("frames", s.frames, 2);
    s.locator = f.Enum("locator",
                       Locator::kFixation,
                       {{"fixation", Locator::kFixation},
                        {"template", Locator::kTemplate},
                        {"apriltag", Locator::kAprilTag},
                        {"lk", Locator::kLk}});
    s.range_m = f.PositiveDouble("range_m", s.range_m);
    s.tolerance_px = f.PositiveDouble("tolerance_px", s.tolerance_px);
    s.max_corrections = f.PositiveInt("max_corrections", s.max_corrections, 0);
    s.latency_frames = f.PositiveInt("latency_frames", 0, 0);
    s.shape = f.Value<bool>("shape", true);
    s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
    return s;
  }
  if (kind == "vor") {
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
    if (s.sines_hz.empty() && s.steps_deg.empty())
      f.Fail("sines_hz", "no sine and no step (steps_deg): nothing to run");
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
    s.locator = f.Enum("locator",
                       Locator::kFixation,
                       {{"fixation", Locator::kFixation},
                        {"template", Locator::kTemplate},
                        {"apriltag", Locator::kAprilTag},
                        {"lk", Locator::kLk}});
    s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
    return s;
  }
  if (kind == "track") {
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
  if (kind == "main-sequence") {
    MainSequenceStep s;
    s.eye = f.Enum("eye", models::kRightEye, {{"left", models::kLeftEye}, {"right", models::kRightEye}});
    s.amplitudes_deg = f.List<double>("amplitudes_deg", s.amplitudes_deg);
    for (double a : s.amplitudes_deg)
      if (!(a >= 0.5 && a <= 45)) f.Fail("amplitudes_deg", std::to_string(a) + " must be in [0.5, 45]");
    s.repeats = f.PositiveInt("repeats", s.repeats);
    s.frames = f.PositiveInt("frames", s.frames, 6);
    s.rest_ms = f.PositiveInt("rest_ms", s.rest_ms, 100);
    s.range_m = f.PositiveDouble("range_m", s.range_m);
    s.locator = f.Enum("locator",
                       Locator::kFixation,
                       {{"fixation", Locator::kFixation},
                        {"template", Locator::kTemplate},
                        {"apriltag", Locator::kAprilTag},
                        {"lk", Locator::kLk}});
    s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
    return s;
  }
  if (kind == "catch-up") {
    CatchUpStep s;
    s.eye = f.Enum("eye", models::kRightEye, {{"left", models::kLeftEye}, {"right", models::kRightEye}});
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
    s.locator = f.Enum("locator",
                       Locator::kFixation,
                       {{"fixation", Locator::kFixation},
                        {"template", Locator::kTemplate},
                        {"apriltag", Locator::kAprilTag},
                        {"lk", Locator::kLk}});
    s.limit_margin_us = f.PulseUs("limit_margin_us", s.limit_margin_us, 0);
    s.hide_after_ms = f.PositiveInt("hide_after_ms", s.hide_after_ms, 0);
    return s;
  }
  throw ProtocolError(f.At(YAML::Node(YAML::NodeType::Undefined)) + "unknown step kind '" + kind +
                      "' (move-to, sweep, grid, place-target, capture, fixate, step-response, limits, "
                      "alignment, latency, wait, saccade, vor, main-sequence, catch-up, track, repeat)");
}

Step ParseStep(
    const std::string& kind, const YAML::Node& body, const std::string& source, const std::string& where, int line) {
  Step s;
  Fields f(body.IsNull() ? YAML::Node(YAML::NodeType::Map) : body, source, where, line);
  s.name = f.Value<std::string>("name", "");
  s.params = ParseStepParams(kind, f, source, where);
  f.RejectUnknown();
  return s;
}

// Steps `list` expands to (repeats multiplied out, saturating above kMaxPlanSteps).
int64_t CountSteps(const YAML::Node& list, const std::string& source, int depth) {
  if (!list || !list.IsSequence()) throw ProtocolError(source + ": field 'steps': expected a list of steps");
  if (depth > 4) throw ProtocolError(source + ": repeat nested too deeply");
  int64_t n = 0;
  for (size_t i = 0; i < list.size() && n <= kMaxPlanSteps; ++i) {
    const YAML::Node item = list[i];
    if (item.IsMap() && item.size() == 1 && item.begin()->first.IsScalar() &&
        item.begin()->first.Scalar() == "repeat" && item.begin()->second.IsMap()) {
      const YAML::Node body = item.begin()->second;
      int times = 1;
      if (body["times"] && body["times"].IsScalar() &&
          !io::CheckInt(body["times"].Scalar(), 1, kMaxPlanInt, &times).empty())
        times = 1;  // ParseSteps names the bad value
      n += std::min<int64_t>(kMaxPlanSteps + 1, times * CountSteps(body["steps"], source, depth + 1));
    } else {
      ++n;
    }
  }
  return std::min<int64_t>(n, kMaxPlanSteps + 1);
}

void ParseSteps(const YAML::Node& list, const std::string& source, const std::string& prefix, Protocol* p, int depth) {
  if (!list || !list.IsSequence()) throw ProtocolError(source + ": field 'steps': expected a list of steps");
  if (depth > 4) throw ProtocolError(source + ": repeat nested too deeply");
  for (size_t i = 0; i < list.size(); ++i) {
    const YAML::Node item = list[i];
    const int line = item.Mark().line;  // 0-based, -1 unknown
    const std::string at = source + (line >= 0 ? ":" + std::to_string(line + 1) : std::string()) + ": ";
    const std::string where = "step " + prefix + std::to_string(i);
    if (!item.IsMap() || item.size() != 1)
      throw ProtocolError(at + where + ": expected one key naming the step kind, e.g. '- sweep: {...}'");
    const std::string kind = item.begin()->first.as<std::string>();
    const YAML::Node body = item.begin()->second;
    const std::string context = where + " (" + kind + ")";
    if (kind == "repeat") {
      Fields f(body, source, context, line);
      const int times = f.PositiveInt("times", 1);
      const YAML::Node inner = f.Get("steps");
      f.Value<std::string>("name", "");
      f.RejectUnknown();
      // The plan is expanded in memory: cap its size before expanding (a repeat of 2e9, or
      // nested repeats of 1000, ended in std::bad_alloc).
      const int64_t each = CountSteps(inner, source, depth + 1);
      if (each * times > kMaxPlanSteps - static_cast<int64_t>(p->steps.size()))
        f.Fail("times",
               std::to_string(times) + " x " + std::to_string(each) + " steps would make the protocol longer than " +
                   std::to_string(kMaxPlanSteps) + " steps");
      for (int k = 0; k < times; ++k) {
        const size_t before = p->steps.size();
        ParseSteps(inner, source, prefix + std::to_string(i) + ".", p, depth + 1);
        const std::string suffix = std::to_string(k + 1);
        for (size_t j = before; j < p->steps.size(); ++j) {
          p->steps[j].name.push_back('#');
          p->steps[j].name.append(suffix);
        }
      }
      continue;
    }
    Step s = ParseStep(kind, body, source, context, line);
    s.file = source;
    s.file_index = static_cast<int>(i);
    s.file_line = line + 1;
    if (s.name.empty()) s.name = kind + std::to_string(p->steps.size());
    p->steps.push_back(std::move(s));
  }
}

}  // namespace

Protocol ParseProtocolYaml(const std::string& yaml_text, const std::string& source) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw ProtocolError(source + ": not valid YAML: " + e.what());
  }
  if (!root.IsMap()) throw ProtocolError(source + ": expected a map with name, target and steps");
  Fields f(root, source, "");
  Protocol p;
  p.text = yaml_text;
  p.name = f.Scalar("name");
  if (p.name.empty()) f.Fail("name", "must not be empty");
  p.description = f.Value<std::string>("description", "");
  p.target = f.Value<std::string>("target", "");
  p.target_description = f.Value<std::string>("target_description", "");
  if (f.Has("targets")) {
    YAML::Node t = f.Get("targets");
    if (!t.IsMap()) f.Fail("targets", "expected a map name -> target definition");
    for (const auto& kv : t) {
      const std::string name = kv.first.as<std::string>();
      p.targets[name] = ParseTarget(kv.second, name, source);
    }
  }
  if (f.Has("tag_targets")) {
    YAML::Node t = f.Get("tag_targets");
    if (!t.IsSequence()) f.Fail("tag_targets", "expected a list of target names");
    for (const auto& n : t) {
      const std::string name = n.as<std::string>();
      const auto it = p.targets.find(name);
      if (it == p.targets.end()) f.Fail("tag_targets", "'" + name + "' is not one of `targets`");
      if (it->second.kind != calib::TargetKind::kAprilGrid) f.Fail("tag_targets", "'" + name + "' is not an aprilgrid");
      if (name == p.target) f.Fail("tag_targets", "'" + name + "' is the protocol's `target`");
      if (std::find(p.tag_targets.begin(), p.tag_targets.end(), name) != p.tag_targets.end())
        f.Fail("tag_targets", "'" + name + "' is listed twice");
      p.tag_targets.push_back(name);
    }
  }
  ParseSteps(f.Get("steps"), source, "", &p, 0);
  f.RejectUnknown();
  return p;
}

Protocol LoadProtocolFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ProtocolError(path + ": cannot open protocol file");
  std::ostringstream s;
  s << in.rdbuf();
  Protocol p = ParseProtocolYaml(s.str(), path);
  p.file = path;
  return p;
}

std::string StandardProtocolDir() {
  if (const char* env = std::getenv("OWLCAL_PROTOCOL_DIR")) return env;
  return std::string(OWLCAL_SOURCE_DIR) + "/protocols/standard";
}

std::vector<std::string> StandardProtocolNames() {
  return {
      "limits", "alignment", "intrinsics", "stereo", "servo_sweep", "vergence", "step_response", "latency", "saccade"};
}

std::string CheckStepForRobot(const Step& s, const models::RobotConfig& robot) {
  const std::string where = s.Where() + ": field '";
  auto range = [&](int servo) { return robot.servos[servo].max_us - robot.servos[servo].min_us; };
  auto at_most = [&](const char* field, int value, int servo) -> std::string {
    if (value <= range(servo)) return "";
    return where + field + "': " + std::to_string(value) + " us is more than " + models::kServoNames[servo] +
           "'s range of " + std::to_string(range(servo)) + " us in the robot file";
  };
  std::string why;
  auto first = [&](const std::string& w) {
    if (why.empty()) why = w;
  };
  auto loop = [&](const ClosedLoopSettings& l) {
    for (int servo = 0; servo < models::kNumServos; ++servo) {
      first(at_most("max_step_us", l.max_step_us, servo));
      if (2 * l.limit_margin_us >= range(servo))
        first(where + "limit_margin_us': " + std::to_string(l.limit_margin_us) + " us leaves no room in " +
              models::kServoNames[servo] + "'s range of " + std::to_string(range(servo)) + " us");
    }
  };
  if (const auto* sw = std::get_if<SweepStep>(&s.params)) first(at_most("step_us", sw->step_us, sw->servo));
  if (const auto* la = std::get_if<LatencyStep>(&s.params)) first(at_most("amplitude_us", la->amplitude_us, la->servo));
  if (const auto* li = std::get_if<LimitsStep>(&s.params))
    for (int servo : li->servos) first(at_most("coarse_us", li->coarse_us, servo));
  if (const auto* fx = std::get_if<FixateStep>(&s.params)) loop(fx->loop);
  if (const auto* sr = std::get_if<StepResponseStep>(&s.params)) loop(sr->loop);
  if (const auto* vo = std::get_if<VorStep>(&s.params)) {
    // The neck's turn at the nominal scale must fit inside its range with the margin.
    const models::ServoConfig& n = robot.servos[models::kNeck];
    double amp = vo->sines_hz.empty() ? 0 : vo->amplitude_deg;
    for (double a : vo->steps_deg) amp = std::max(amp, a);
    const double us = amp / n.nominal_deg_per_us;
    const double room = std::min(n.centre_us - n.min_us, n.max_us - n.centre_us) - vo->limit_margin_us;
    if (us > room)
      first(where + "amplitude_deg': " + std::to_string(amp) + " deg (" + std::to_string(int(std::lround(us))) +
            " us of Neck) does not fit in the " + std::to_string(int(room)) +
            " us between Neck's centre and its limits' margin in the robot file");
  }
  if (const auto* ms = std::get_if<MainSequenceStep>(&s.params)) {
    // The largest saccade at the nominal scale must fit inside the pan servo's range with the margin.
    const int servo = models::kPanServo[ms->eye];
    const models::ServoConfig& c = robot.servos[servo];
    double amp = 0;
    for (double a : ms->amplitudes_deg) amp = std::max(amp, a);
    const double us = amp / c.nominal_deg_per_us;
    if (us > range(servo) - 2 * ms->limit_margin_us)
      first(where + "amplitudes_deg': " + std::to_string(amp) + " deg (" + std::to_string(int(std::lround(us))) +
            " us of " + models::kServoNames[servo] + ") does not fit in its range of " + std::to_string(range(servo)) +
            " us with the limits' margin");
  }
  if (const auto* sa = std::get_if<SaccadeStep>(&s.params))
    for (int servo = 0; servo < models::kNumServos; ++servo)
      if (2 * sa->limit_margin_us >= range(servo))
        first(where + "limit_margin_us': " + std::to_string(sa->limit_margin_us) + " us leaves no room in " +
              models::kServoNames[servo] + "'s range of " + std::to_string(range(servo)) + " us");
  return why;
}

std::map<std::string, calib::TargetDefinition> TargetsOfDataset(const std::string& dataset) {
  std::map<std::string, calib::TargetDefinition> out;
  const nlohmann::json m = ReadManifest(dataset);
  for (const auto& p : m.value("protocols", nlohmann::json::array())) {
    if (!p.contains("text") || !p["text"].is_string()) continue;
    for (const auto& [name, def] : ParseProtocolYaml(p["text"].get<std::string>(), dataset + "/manifest.json").targets)
      out[name] = def;
  }
  return out;
}

std::string ResolveProtocolPath(const std::string& name_or_path) {
  if (fs::exists(name_or_path)) return name_or_path;
  std::string stem = name_or_path;
  if (stem.size() > 5 && stem.substr(stem.size() - 5) == ".yaml") stem = stem.substr(0, stem.size() - 5);
  const std::string p = StandardProtocolDir() + "/" + stem + ".yaml";
  if (fs::exists(p)) return p;
  throw ProtocolError(name_or_path + ": no such protocol file, and not a standard protocol in " +
                      StandardProtocolDir());
}

}  // namespace owlcal::protocols
