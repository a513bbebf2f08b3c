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

FixationResult RunFixation(const FixationOptions& o,
                           const models::RobotConfig& robot,
                           TargetLocator& locator,
                           const FixationIo& io) {
  FixationResult r;
  std::string why;
  if (!o.Check(&why)) {
    r.message = why;
    return r;
  }
  const models::PwmVector start = io.command();
  std::array<double, models::kNumServos> state;
  for (int i = 0; i < models::kNumServos; ++i) state[i] = start[i];
  models::PwmVector sent = start;
  PeakTracker peaks[2][2];
  CrossingTracker crossings[2][2];
  double initial_err[2] = {-1, -1};
  int lost = 0, still = 0, wait = 0;
  std::array<int, models::kNumServos> last_dir{};  // sign of each servo's last command change
  for (int k = 0; k < o.max_iterations; ++k) {
    const robot::StereoFrame frame = io.grab();
    if (k == 0 && !locator.Prepare(frame, &why)) {
      r.outcome = FixationResult::Outcome::kNotStarted;
      r.message = why;
      r.final_pwm_us = sent;
      return r;
    }
    FixationSample s;
    s.k = k;
    s.stamp_ns = frame.stamp_ns;
    s.pwm_us = sent;
    bool all_found = true;
    double eye_err[2] = {0, 0};
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      const cv::Mat img = e == models::kLeftEye ? frame.left : frame.right;
      const auto p = locator.Locate(img, e);
      if (!p) {
        all_found = false;
        continue;
      }
      s.found[e] = true;
      s.offset_px[e] = *p - Eigen::Vector2d((img.cols - 1) / 2.0, (img.rows - 1) / 2.0);
      s.radius_px[e] = locator.LastRadiusPx(e);
      r.found[e] = true;
      r.residual_px[e] = s.offset_px[e];
      r.radius_px[e] = s.radius_px[e];
      const double err =
          std::max(o.pan ? std::abs(s.offset_px[e].x()) : 0.0, o.tilt ? std::abs(s.offset_px[e].y()) : 0.0);
      eye_err[e] = err;
      if (initial_err[e] < 0) initial_err[e] = err;
      peaks[e][0].Add(s.offset_px[e].x(), o.tolerance_px);
      peaks[e][1].Add(s.offset_px[e].y(), o.tolerance_px);
      for (int a = 0; a < 2; ++a) crossings[e][a].Add(s.offset_px[e][a], std::max(3 * o.tolerance_px, 16.0));
    }
    r.trace.push_back(s);
    r.iterations = k + 1;
    if (!all_found) {
      if (++lost >= o.lost_frames) {
        r.outcome = FixationResult::Outcome::kLost;
        r.message = "target not found in " + std::to_string(lost) + " consecutive frames";
        // The locator's own reason (an LK track says why it was lost).
        for (int e = 0; e < 2; ++e)
          if (o.eyes[e] && !s.found[e])
            if (const std::string why_lost = locator.LastReason(e); !why_lost.empty())
              r.message += std::string(" (") + models::kEyeNames[e] + " eye: " + why_lost + ")";
        r.final_pwm_us = sent;
        return r;
      }
      continue;
    }
    lost = 0;
    // Divergence: growing oscillation or error far beyond its start.
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      for (int a = 0; a < 2; ++a) {
        if ((a == 0 && !o.pan) || (a == 1 && !o.tilt)) continue;
        if (peaks[e][a].Growing(3 * o.tolerance_px)) {
          r.outcome = FixationResult::Outcome::kDiverged;
          r.message = std::string(models::kEyeNames[e]) + (a == 0 ? " pan" : " tilt") +
                      ": oscillation does not decay (half-cycle peaks " +
                      std::to_string(peaks[e][a].peaks[peaks[e][a].peaks.size() - 2]) + " -> " +
                      std::to_string(peaks[e][a].peaks.back()) + " px) at gain " + std::to_string(o.gain);
          r.final_pwm_us = sent;
          return r;
        }
      }
      if (initial_err[e] >= 0 && eye_err[e] > 2 * std::max(initial_err[e], 10.0)) {
        r.outcome = FixationResult::Outcome::kDiverged;
        r.message = std::string(models::kEyeNames[e]) + " error grew to " + std::to_string(eye_err[e]) + " px from " +
                    std::to_string(initial_err[e]) + " px at gain " + std::to_string(o.gain);
        r.final_pwm_us = sent;
        return r;
      }
    }
    if (wait > 0) {
      --wait;
      continue;
    }
    // Proportional update.
    models::PwmVector next = sent;
    for (int e = 0; e < 2; ++e) {
      if (!o.eyes[e]) continue;
      const Eigen::Vector2d err_us = OffsetToPulseError(s.offset_px[e], e, robot, o.focal_px);
      const int servos[2] = {models::kPanServo[e], models::kTiltServo[e]};
      for (int a = 0; a < 2; ++a) {
        if ((a == 0 && !o.pan) || (a == 1 && !o.tilt)) continue;
        // Dead zone: an axis already within the tolerance is left alone (with backlash an
        // integrating loop would otherwise chase it in a limit cycle); widened to what the
        // servo can resolve once the target was seen to jump across the centre.
        if (std::abs(s.offset_px[e][a]) <= crossings[e][a].DeadZone(o.tolerance_px)) continue;
        const double step = std::clamp(o.gain * err_us[a], -double(o.max_step_us), double(o.max_step_us));
        state[servos[a]] += step;
        next[servos[a]] = static_cast<int>(std::lround(state[servos[a]]));
      }
    }
    // Heading for a limit: stop before sending.
    for (int i = 0; i < models::kNumServos; ++i) {
      if (next[i] == sent[i]) continue;
      const models::ServoConfig& c = robot.servos[i];
      if (next[i] < c.min_us + o.limit_margin_us || next[i] > c.max_us - o.limit_margin_us) {
        r.outcome = FixationResult::Outcome::kLimit;
        r.message = std::string(models::kServoNames[i]) + " would go to " + std::to_string(next[i]) + " us, within " +
                    std::to_string(o.limit_margin_us) + " us of its limit [" + std::to_string(c.min_us) + ", " +
                    std::to_string(c.max_us) + "]: stopped before sending";
        r.final_pwm_us = sent;
        return r;
      }
    }
    const bool unchanged = next == sent;
    bool within = true;
    for (int e = 0; e < 2; ++e)
      for (int a = 0; a < 2; ++a)
        if (o.eyes[e] && ((a == 0 && o.pan) || (a == 1 && o.tilt)))
          within &= std::abs(s.offset_px[e][a]) <= crossings[e][a].DeadZone(o.tolerance_px);
    if (unchanged && within) {
      if (++still >= o.still_frames && o.stop_when_converged) {
        r.outcome = FixationResult::Outcome::kConverged;
        r.message = "converged in " + std::to_string(k + 1) + " frames";
        for (int e = 0; e < 2; ++e)
          for (int a = 0; a < 2; ++a)
            if (crossings[e][a].DeadZone(o.tolerance_px) > o.tolerance_px)
              r.message += std::string(", ") + models::kEyeNames[e] + (a == 0 ? " pan" : " tilt") + " within " +
                           std::to_string(crossings[e][a].DeadZone(o.tolerance_px)).substr(0, 4) +
                           " px (the target jumps across the centre by " +
                           std::to_string(crossings[e][a].min_jump).substr(0, 4) + " px: PWM step or dead band)";
        r.final_pwm_us = sent;
        if (o.seat_grid_us > 0) SeatCommand(o, robot, locator, io, last_dir, &r);
        return r;
      }
    } else {
      still = 0;
    }
    if (!unchanged) {
      for (int i = 0; i < models::kNumServos; ++i)
        if (next[i] != sent[i]) last_dir[i] = next[i] > sent[i] ? 1 : -1;
      io.send(next);
      sent = io.command();
      wait = o.latency_frames;
    }
  }
  r.final_pwm_us = sent;
  r.outcome = still >= o.still_frames ? FixationResult::Outcome::kConverged : FixationResult::Outcome::kMaxIterations;
  r.message = r.outcome == FixationResult::Outcome::kConverged
                  ? "converged (ran all frames)"
                  : "not converged in " + std::to_string(o.max_iterations) + " frames";
  return r;
}

}  // namespace owlcal::protocols
