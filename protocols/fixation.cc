#include "protocols/fixation.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>

#include "models/head_model.h"
#include "protocols/fixation_seat.h"

namespace owlcal::protocols {
namespace {

// Half-cycle peak tracker of one error signal.
struct PeakTracker {
  int sign = 0;
  double peak = 0;
  std::vector<double> peaks;
  void Add(double e, double dead) {
    const int s = e > dead ? 1 : (e < -dead ? -1 : 0);
    if (s == 0) return;
    if (sign != 0 && s != sign) {
      peaks.push_back(peak);
      peak = 0;
    }
    sign = s;
    peak = std::max(peak, std::abs(e));
  }
  // Two consecutive completed half-cycles whose peaks grew (a sustained small limit cycle
  // from backlash is not divergence).
  bool Growing(double floor) const {
    const size_t n = peaks.size();
    if (n < 3) return false;
    return peaks[n - 1] > floor && peaks[n - 1] > 1.05 * peaks[n - 2] && peaks[n - 2] > 1.05 * peaks[n - 3];
  }
};

// A limit cycle across the target on one axis: a servo with a PWM step or dead band
// (models/servo_resolution.h) makes the image jump across the centre between two plateaus and
// cannot put the target closer. Each half-cycle (between two sign changes of the offset, all
// within near_px) gives the plateau on its side: the median |offset| over its frames (the loop
// crawls through the servo's bin for many frames; the few frames of the jump do not count).
struct CrossingTracker {
  int sign = 0;
  int crossings = 0;
  std::vector<double> half;      // |offset| in the current half-cycle
  double plateau[2] = {-1, -1};  // [0] negative side, [1] positive side; -1 unknown
  double min_jump = 0;           // smallest |e_after - e_before| at a crossing
  double last = 0;
  void Add(double e, double near_px) {
    const int s = e > 0 ? 1 : (e < 0 ? -1 : 0);
    if (s == 0) return;
    if (std::abs(e) > near_px) {  // far from the target: no cycle (yet)
      *this = CrossingTracker{};
      return;
    }
    if (sign != 0 && s != sign) {
      std::vector<double> v = half;
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      plateau[sign > 0] = v[v.size() / 2];
      const double jump = std::abs(e - last);
      min_jump = crossings == 0 ? jump : std::min(min_jump, jump);
      ++crossings;
      half.clear();
    }
    half.push_back(std::abs(e));
    sign = s;
    last = e;
  }
  // After a full cycle (both plateaus known), the dead zone takes in the worse plateau (the loop
  // stops on whichever side it is), at least the tolerance.
  double DeadZone(double tolerance_px) const {
    if (crossings < 2 || plateau[0] < 0 || plateau[1] < 0) return tolerance_px;
    return std::max(tolerance_px, 1.05 * std::max(plateau[0], plateau[1]));
  }
};

}  // namespace

double NominalFocalPx(const models::RobotConfig& robot) { return 585.0 * robot.image_width / 640.0; }

const char* OutcomeName(FixationResult::Outcome o) {
  switch (o) {
    case FixationResult::Outcome::kConverged:
      return "converged";
    case FixationResult::Outcome::kMaxIterations:
      return "max-iterations";
    case FixationResult::Outcome::kDiverged:
      return "diverged";
    case FixationResult::Outcome::kLimit:
      return "heading-for-limit";
    case FixationResult::Outcome::kLost:
      return "target-lost";
    case FixationResult::Outcome::kNotStarted:
      return "not-started";
  }
  return "?";
}

calib::TrialStatus FixationStatus(const FixationResult& r, const FixationOptions& o, std::string* reason) {
  using Outcome = FixationResult::Outcome;
  reason->clear();
  switch (r.outcome) {
    case Outcome::kConverged:
      for (int e = 0; e < 2; ++e)
        if (o.eyes[e] && !r.found[e]) {
          *reason = std::string("target not found in the ") + models::kEyeNames[e] + " eye at the end";
          return calib::TrialStatus::kLostTarget;
        }
      return calib::TrialStatus::kOk;
    case Outcome::kLost:
      *reason = r.message;
      return calib::TrialStatus::kLostTarget;
    case Outcome::kMaxIterations:
      *reason = r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kDiverged:
      *reason = "diverged: " + r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kLimit:
      *reason = "stopped before a limit: " + r.message;
      return calib::TrialStatus::kNotSettled;
    case Outcome::kNotStarted:
      *reason = "could not start: " + r.message;
      return calib::TrialStatus::kFailed;
  }
  *reason = r.message;
  return calib::TrialStatus::kFailed;
}

bool FixationOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "fixation options: " + m;
    return false;
  };
  if (!eyes[0] && !eyes[1]) return fail("no eye selected");
  if (!pan && !tilt) return fail("no axis selected");
  if (!(gain > 0 && gain < 5)) return fail("gain " + std::to_string(gain) + " must be in (0, 5)");
  if (max_iterations < 1) return fail("max_iterations " + std::to_string(max_iterations) + " must be >= 1");
  if (!(tolerance_px > 0)) return fail("tolerance_px must be > 0");
  if (latency_frames < 0) return fail("latency_frames must be >= 0");
  if (max_step_us < 1) return fail("max_step_us must be >= 1");
  if (!(focal_px > 0)) return fail("focal_px must be > 0");
  if (seat_grid_us < 0 || seat_back_us < 1 || seat_frames < 1 || seat_average < 1)
    return fail("seat_grid_us must be >= 0 and seat_back_us, seat_frames, seat_average >= 1");
  return true;
}

Eigen::Vector2d OffsetToPulseError(const Eigen::Vector2d& offset_px,
                                   int eye,
                                   const models::RobotConfig& robot,
                                   double focal_px) {
  const models::ServoConfig& pan = robot.servos[models::kPanServo[eye]];
  const models::ServoConfig& tilt = robot.servos[models::kTiltServo[eye]];
  const double pan_deg = std::atan(offset_px.x() / focal_px) * 180.0 / M_PI;
  const double tilt_deg = std::atan(-offset_px.y() / focal_px) * 180.0 / M_PI;
  return Eigen::Vector2d(pan.direction * pan_deg / pan.nominal_deg_per_us,
                         tilt.direction * tilt_deg / tilt.nominal_deg_per_us);
}

namespace {

// The target seen in one frame: the sample, whether every controlled eye found it, and each
// eye's largest controlled offset [px].
struct FixationLook {
  FixationSample sample;
  bool all_found = true;
  double eye_err[2] = {0, 0};
};

// The loop of RunFixation, one stage per method; its state is what carries from frame to frame:
// the command as a real number, the command sent, the error trackers per eye and axis, and the
// counters of lost, still and waiting frames.
class FixationLoop {
 public:
  using Outcome = FixationResult::Outcome;

  FixationLoop(const FixationOptions& o, const models::RobotConfig& robot, TargetLocator& locator, const FixationIo& io)
      : o_(o), robot_(robot), locator_(locator), io_(io), sent_(io.command()) {
    for (int i = 0; i < models::kNumServos; ++i) state_[i] = sent_[i];
  }

  FixationResult Run() {
    std::string why;
    for (int k = 0; k < o_.max_iterations; ++k) {
      const robot::StereoFrame frame = io_.grab();
      if (k == 0 && !locator_.Prepare(frame, &why)) return Stop(Outcome::kNotStarted, why);
      const FixationLook look = Observe(frame, k);
      if (!look.all_found) {
        if (++lost_ >= o_.lost_frames) return Stop(Outcome::kLost, LostMessage(look.sample));
        continue;
      }
      lost_ = 0;
      if (const auto diverged = Divergence(look)) return Stop(Outcome::kDiverged, *diverged);
      if (wait_ > 0) {
        --wait_;
        continue;
      }
      const models::PwmVector next = ProportionalUpdate(look.sample);
      if (const auto limit = LimitStop(next)) return Stop(Outcome::kLimit, *limit);
      const bool unchanged = next == sent_;
      if (unchanged && WithinDeadZones(look.sample)) {
        if (++still_ >= o_.still_frames && o_.stop_when_converged) return Converge(k + 1);
      } else {
        still_ = 0;
      }
      if (!unchanged) Send(next);
    }
    r_.final_pwm_us = sent_;
    r_.outcome = still_ >= o_.still_frames ? Outcome::kConverged : Outcome::kMaxIterations;
    r_.message = r_.outcome == Outcome::kConverged
                     ? "converged (ran all frames)"
                     : "not converged in " + std::to_string(o_.max_iterations) + " frames";
    return r_;
  }

 private:
  // Axis a (0 pan, 1 tilt) is under control.
  bool Controlled(int a) const { return a == 0 ? o_.pan : o_.tilt; }

  FixationResult Stop(Outcome outcome, const std::string& message) {
    r_.outcome = outcome;
    r_.message = message;
    r_.final_pwm_us = sent_;
    return r_;
  }

  // Locates the target in each controlled eye of frame k and feeds the offsets to the result
  // and the trackers.
  FixationLook Observe(const robot::StereoFrame& frame, int k) {
    FixationLook look;
    FixationSample& s = look.sample;
    s.k = k;
    s.stamp_ns = frame.stamp_ns;
    s.pwm_us = sent_;
    for (int e = 0; e < 2; ++e) {
      if (!o_.eyes[e]) continue;
      const cv::Mat img = e == models::kLeftEye ? frame.left : frame.right;
      const auto p = locator_.Locate(img, e);
      if (!p) {
        look.all_found = false;
        continue;
      }
      s.found[e] = true;
      s.offset_px[e] = *p - ImageCentre(img);
      s.radius_px[e] = locator_.LastRadiusPx(e);
      r_.found[e] = true;
      r_.residual_px[e] = s.offset_px[e];
      r_.radius_px[e] = s.radius_px[e];
      const double err =
          std::max(o_.pan ? std::abs(s.offset_px[e].x()) : 0.0, o_.tilt ? std::abs(s.offset_px[e].y()) : 0.0);
      look.eye_err[e] = err;
      if (initial_err_[e] < 0) initial_err_[e] = err;
      peaks_[e][0].Add(s.offset_px[e].x(), o_.tolerance_px);
      peaks_[e][1].Add(s.offset_px[e].y(), o_.tolerance_px);
      for (int a = 0; a < 2; ++a) crossings_[e][a].Add(s.offset_px[e][a], std::max(3 * o_.tolerance_px, 16.0));
    }
    r_.trace.push_back(s);
    r_.iterations = k + 1;
    return look;
  }

  // Why the target counts as lost, with the locator's own reason (an LK track says why).
  std::string LostMessage(const FixationSample& s) const {
    std::string message = "target not found in " + std::to_string(lost_) + " consecutive frames";
    for (int e = 0; e < 2; ++e)
      if (o_.eyes[e] && !s.found[e])
        if (const std::string why_lost = locator_.LastReason(e); !why_lost.empty())
          message += std::string(" (") + models::kEyeNames[e] + " eye: " + why_lost + ")";
    return message;
  }

  // Divergence: a growing oscillation or an error far beyond its start; nullopt when neither.
  std::optional<std::string> Divergence(const FixationLook& look) const {
    for (int e = 0; e < 2; ++e) {
      if (!o_.eyes[e]) continue;
      for (int a = 0; a < 2; ++a) {
        if (!Controlled(a) || !peaks_[e][a].Growing(3 * o_.tolerance_px)) continue;
        const std::vector<double>& p = peaks_[e][a].peaks;
        return std::string(models::kEyeNames[e]) + (a == 0 ? " pan" : " tilt") +
               ": oscillation does not decay (half-cycle peaks " + std::to_string(p[p.size() - 2]) + " -> " +
               std::to_string(p.back()) + " px) at gain " + std::to_string(o_.gain);
      }
      if (initial_err_[e] >= 0 && look.eye_err[e] > 2 * std::max(initial_err_[e], 10.0))
        return std::string(models::kEyeNames[e]) + " error grew to " + std::to_string(look.eye_err[e]) + " px from " +
               std::to_string(initial_err_[e]) + " px at gain " + std::to_string(o_.gain);
    }
    return std::nullopt;
  }

  // The proportional update of every controlled axis outside its dead zone: an axis already
  // within the tolerance is left alone (with backlash an integrating loop would otherwise chase
  // it in a limit cycle), widened to what the servo can resolve once the target was seen to
  // jump across the centre.
  models::PwmVector ProportionalUpdate(const FixationSample& s) {
    models::PwmVector next = sent_;
    for (int e = 0; e < 2; ++e) {
      if (!o_.eyes[e]) continue;
      const Eigen::Vector2d err_us = OffsetToPulseError(s.offset_px[e], e, robot_, o_.focal_px);
      const int servos[2] = {models::kPanServo[e], models::kTiltServo[e]};
      for (int a = 0; a < 2; ++a) {
        if (!Controlled(a)) continue;
        if (std::abs(s.offset_px[e][a]) <= crossings_[e][a].DeadZone(o_.tolerance_px)) continue;
        const double step = std::clamp(o_.gain * err_us[a], -double(o_.max_step_us), double(o_.max_step_us));
        state_[servos[a]] += step;
        next[servos[a]] = static_cast<int>(std::lround(state_[servos[a]]));
      }
    }
    return next;
  }

  // Heading for a limit: why the loop stops before sending next; nullopt when it need not.
  std::optional<std::string> LimitStop(const models::PwmVector& next) const {
    std::string why = models::OutsideMargin(robot_, next, o_.limit_margin_us, "stopped before sending", &sent_);
    if (why.empty()) return std::nullopt;
    return why;
  }

  bool WithinDeadZones(const FixationSample& s) const {
    bool within = true;
    for (int e = 0; e < 2; ++e)
      for (int a = 0; a < 2; ++a)
        if (o_.eyes[e] && Controlled(a))
          within &= std::abs(s.offset_px[e][a]) <= crossings_[e][a].DeadZone(o_.tolerance_px);
    return within;
  }

  // Converged after `frames` frames: the message names every axis whose dead zone a limit cycle
  // widened; the command is then seated (FixationOptions seat_*).
  FixationResult Converge(int frames) {
    std::string message = "converged in " + std::to_string(frames) + " frames";
    for (int e = 0; e < 2; ++e)
      for (int a = 0; a < 2; ++a)
        if (crossings_[e][a].DeadZone(o_.tolerance_px) > o_.tolerance_px)
          message += std::string(", ") + models::kEyeNames[e] + (a == 0 ? " pan" : " tilt") + " within " +
                     std::to_string(crossings_[e][a].DeadZone(o_.tolerance_px)).substr(0, 4) +
                     " px (the target jumps across the centre by " +
                     std::to_string(crossings_[e][a].min_jump).substr(0, 4) + " px: PWM step or dead band)";
    Stop(Outcome::kConverged, message);
    if (o_.seat_grid_us > 0) SeatCommand(o_, robot_, locator_, io_, last_dir_, &r_);
    return r_;
  }

  void Send(const models::PwmVector& next) {
    for (int i = 0; i < models::kNumServos; ++i)
      if (next[i] != sent_[i]) last_dir_[i] = next[i] > sent_[i] ? 1 : -1;
    io_.send(next);
    sent_ = io_.command();
    wait_ = o_.latency_frames;
  }

  const FixationOptions& o_;
  const models::RobotConfig& robot_;
  TargetLocator& locator_;
  const FixationIo& io_;
  FixationResult r_;
  models::PwmVector sent_;
  std::array<double, models::kNumServos> state_;  // the command as a real number [us]
  PeakTracker peaks_[2][2];
  CrossingTracker crossings_[2][2];
  double initial_err_[2] = {-1, -1};
  int lost_ = 0, still_ = 0, wait_ = 0;
  std::array<int, models::kNumServos> last_dir_{};  // sign of each servo's last command change
};

}  // namespace

FixationResult RunFixation(const FixationOptions& o,
                           const models::RobotConfig& robot,
                           TargetLocator& locator,
                           const FixationIo& io) {
  std::string why;
  if (!o.Check(&why)) {
    FixationResult r;
    r.message = why;
    return r;
  }
  return FixationLoop(o, robot, locator, io).Run();
}

}  // namespace owlcal::protocols
