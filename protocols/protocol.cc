// The protocol types' helpers (pulse-width expressions, step kind and setting names, what a step
// detects), servo names, and where protocol files are found. Parsing: protocols/protocol_parse.cc
// and protocols/protocol_steps.cc; checking against a robot: protocols/protocol_robot_check.cc.
#include "protocols/protocol.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>

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

std::string StandardProtocolDir() {
  if (const char* env = std::getenv("OWLCAL_PROTOCOL_DIR")) return env;
  return std::string(OWLCAL_SOURCE_DIR) + "/protocols/standard";
}

std::vector<std::string> StandardProtocolNames() {
  return {
      "limits", "alignment", "intrinsics", "stereo", "servo_sweep", "vergence", "step_response", "latency", "saccade"};
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
