#include "protocols/saccade_step.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "calib/trial_status.h"
#include "models/saccade.h"
#include "models/units.h"
#include "protocols/fixate_step.h"

namespace owlcal::protocols {
namespace {

using models::kNumServos;
using models::PwmVector;
constexpr double kDefaultFrameS = 1.0 / 30;    // the Owl's stream
constexpr int kSaccadeDefaultDelayFrames = 4;  // 133 ms: the course's stream latency, rounded up
constexpr int kSaccadeLostFrames = 5;
constexpr int kAcquireFrames = 30;

struct Sample {
  int64_t stamp_ns = 0;
  bool found = false;
  Eigen::Vector2d offset_px = Eigen::Vector2d::Zero();
  PwmVector pwm_us{};
};

struct LoopResult {
  enum class End { kSettled, kFrames, kLost, kLimit, kFailed };
  End end = End::kFrames;
  std::vector<Sample> trace;
  int moves = 0;        // commands computed and sent: the saccade, then corrections
  std::string saccade;  // the first move, described
  std::string message;  // why it ended
  bool found_at_end = false;
  bool at_resolution = false;  // the last usable frame's map pulses were the command in force
  Eigen::Vector2d final_offset_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  double dead_zone_px[2] = {0, 0};
};

class SaccadeController {
 public:
  SaccadeController(RunContext& run, const Protocol& p, const SaccadeStep& s)
      : run_(run), s_(s), eye_(s.eye), loc_(MakeStepLocator(run, p, s.locator)) {
    const auto& cal = run.options().calibration;
    head_ = cal ? cal->head : models::NominalHeadModel(run.config());
    map_name_ = cal ? "calibrated map (" + cal->source + ")" : std::string("nominal map (robot file: no calibration)");
    const int servos[2] = {models::kPanServo[eye_], models::kTiltServo[eye_]};
    const double focal = head_.intrinsics[eye_].params[0];
    for (int a = 0; a < 2; ++a) {
      const int i = servos[a];
      const double px_per_us = focal * std::tan(std::abs(head_.servo_params[i][1]) * kDeg);
      const double res_us = cal ? cal->resolution_us[i] : 0.0;
      dead_zone_px_[a] = std::max(s.tolerance_px, 0.5 * res_us * px_per_us);
      if (cal && cal->slew_us_per_s[i] > 0) slew_us_per_s_[a] = cal->slew_us_per_s[i];
      if (cal && cal->lag_s[i] > 0) lag_s_[a] = cal->lag_s[i];
    }
    if (cal) pwm_step_us_ = cal->pwm_step_us;
    delay_s_ = s.latency_frames > 0               ? s.latency_frames * kDefaultFrameS
               : cal && cal->exposure_delay_s > 0 ? cal->exposure_delay_s
                                                  : kSaccadeDefaultDelayFrames * kDefaultFrameS;
  }

  const std::string& map_name() const { return map_name_; }

  // The pulse for goal_us: on the servo's PWM step grid when the step is known and coarser than
  // 1 us (a pulse off the grid is rounded by the servo, so the correction would alternate
  // between the two neighbours of the one it means), else the nearest microsecond.
  int Seat(int servo, double goal_us) const {
    const int step = pwm_step_us_[servo];
    return step > 1 ? int(std::lround(goal_us / step)) * step : int(std::lround(goal_us));
  }

  // Runs the controller on the axes asked for, for at most `frames` frames; stops when settled
  // if asked (the acquisition), else logs all of them.
  LoopResult Run(bool pan, bool tilt, int frames, bool stop_when_settled) {
    LoopResult r;
    r.dead_zone_px[0] = dead_zone_px_[0];
    r.dead_zone_px[1] = dead_zone_px_[1];
    int lost = 0, still = 0, stuck = 0;
    int64_t last_stamp = -1;
    double frame_s = kDefaultFrameS;
    bool prepared = false;
    // Past `frames` (up to 3 times as many), a trial goes on until the last move's result has been
    // seen on two frames: on a slow stream a correction sent late in the trial is not cut off.
    // It also goes on while the target is still arriving or a correction is due: on a laggy servo
    // the joint's last degree can take longer than the frames allowed.
    const int max_frames = stop_when_settled ? frames : 3 * frames;
    bool busy = false;  // the last frame acted on saw the target still arriving or off the centre
    for (int k = 0; k < max_frames; ++k) {
      if (k >= frames && !busy && last_stamp >= ready_ns_ + int64_t(2 * frame_s * 1e9)) break;
      const robot::StereoFrame frame = run_.Grab();
      if (last_stamp >= 0 && frame.stamp_ns > last_stamp) {
        const double dt = (frame.stamp_ns - last_stamp) * 1e-9;
        if (dt > 0.01 && dt < 0.2) frame_s = std::min(frame_s, dt);  // a skipped frame doubles dt
      }
      last_stamp = frame.stamp_ns;
      std::string why;
      if (!prepared) {
        if (!loc_->Prepare(frame, &why)) {
          r.end = LoopResult::End::kFailed;
          r.message = "could not start: " + why;
          return r;
        }
        prepared = true;
      }
      Sample smp;
      smp.stamp_ns = frame.stamp_ns;
      smp.pwm_us = run_.cmd();
      const cv::Mat& img = eye_ == models::kLeftEye ? frame.left : frame.right;
      std::optional<Eigen::Vector2d> px = loc_->Locate(img, eye_);
      if (!px && s_.locator == Locator::kFixation) {
        // The disc jumped out of the tracker's window (a saccade moves it ~100 px in a frame):
        // search the whole image again.
        loc_->Prepare(frame, &why);
        px = loc_->Locate(img, eye_);
      }
      const Eigen::Vector2d centre = ImageCentre(img);
      if (px) {
        smp.found = true;
        smp.offset_px = *px - centre;
      }
      r.trace.push_back(smp);
      r.found_at_end = smp.found;
      if (smp.found) r.final_offset_px = smp.offset_px;
      if (frame.stamp_ns < ready_ns_) continue;  // exposed before the joint could have arrived
      if (!smp.found) {
        if (++lost >= kSaccadeLostFrames) {
          r.end = LoopResult::End::kLost;
          r.message = "target not found in " + std::to_string(lost) + " consecutive frames";
          return r;
        }
        continue;
      }
      lost = 0;
      // Still arriving: the target moved by more than the dead zone since the frame before (the
      // wait above is only as long as the fitted motion says; a slew fitted too fast ends it
      // early). A correction taken now would overshoot: wait for a frame that agrees with the
      // one before it.
      if (r.trace.size() >= 2 && r.trace[r.trace.size() - 2].found) {
        const Eigen::Vector2d d = smp.offset_px - r.trace[r.trace.size() - 2].offset_px;
        if ((pan && std::abs(d.x()) > dead_zone_px_[0]) || (tilt && std::abs(d.y()) > dead_zone_px_[1])) {
          still = 0;
          busy = true;
          continue;
        }
      }
      const bool within = (!pan || std::abs(smp.offset_px.x()) <= dead_zone_px_[0]) &&
                          (!tilt || std::abs(smp.offset_px.y()) <= dead_zone_px_[1]);
      busy = !within && r.moves <= s_.max_corrections;
      if (within) {
        if (++still >= 2 && stop_when_settled) {
          r.end = LoopResult::End::kSettled;
          r.message = "settled after " + std::to_string(r.moves) + " moves";
          return r;
        }
        continue;
      }
      still = 0;
      if (r.moves > s_.max_corrections) continue;  // no more corrections: log the rest
      // The pulses that put the target on the image centre (where the offsets are measured
      // from, as the P loop's), from the map.
      std::optional<std::array<double, 2>> goal = Goal(*px, centre, pan, tilt, -1);
      // The axis that moves more decides the move's timing and, for the shaped first move, is
      // reached from beyond (its overdrive): solve again with that approach.
      const int servos[2] = {models::kPanServo[eye_], models::kTiltServo[eye_]};
      int major = pan ? 0 : 1;
      if (goal && pan && tilt &&
          std::abs((*goal)[1] - run_.cmd()[servos[1]]) > std::abs((*goal)[0] - run_.cmd()[servos[0]]))
        major = 1;
      const bool shaped = r.moves == 0 && Shaped(major);
      if (goal && shaped) goal = Goal(*px, centre, pan, tilt, major);
      if (!goal) {
        r.end = LoopResult::End::kFailed;
        r.message =
            "the map cannot centre the target at (" + FixedText(px->x(), 1) + ", " + FixedText(px->y(), 1) + ") px";
        return r;
      }
      PwmVector target = run_.cmd();
      if (pan) target[servos[0]] = Seat(servos[0], (*goal)[0]);
      if (tilt) target[servos[1]] = Seat(servos[1], (*goal)[1]);
      if (target == run_.cmd()) {
        // The servo cannot resolve the rest: nothing to send, and nothing left to wait for.
        r.at_resolution = true;
        busy = false;
        if (++stuck >= 2 && stop_when_settled) {
          r.end = LoopResult::End::kSettled;
          r.message = "settled after " + std::to_string(r.moves) + " moves (the rest is below one pulse)";
          return r;
        }
        continue;
      }
      if (const std::string lim = OutsideMargin(target); !lim.empty()) {
        r.end = LoopResult::End::kLimit;
        r.message = lim;
        return r;
      }
      stuck = 0;
      r.at_resolution = false;
      const int64_t sent_ns = run_.robot().NowNs();
      const double move_s = Move(target, major, shaped, r.moves == 0, &r);
      ++r.moves;
      Expect(sent_ns, move_s);
    }
    r.end = LoopResult::End::kFrames;
    r.message = "ran " + std::to_string(r.trace.size()) + " frames, " + std::to_string(r.moves) + " moves";
    return r;
  }

  // A move of `servo` by delta_us sent at sent_ns by someone else (the step away, the way back):
  // frames exposed before it could have arrived are not acted on.
  void Moved(int servo, double delta_us, int64_t sent_ns) {
    const int a = servo == models::kPanServo[eye_] ? 0 : 1;
    Expect(sent_ns, MoveTime(a, servo, delta_us));
  }

 private:
  // The map's pulses [pan, tilt] (real-valued) that centre the target seen at `px`, reached from
  // the side each servo will approach from.
  std::optional<std::array<double, 2>> Goal(
      const Eigen::Vector2d& px, const Eigen::Vector2d& centre, bool pan, bool tilt, int beyond_axis) const {
    std::array<double, kNumServos> u{};
    std::array<int, kNumServos> approach{};
    for (int i = 0; i < kNumServos; ++i) {
      u[i] = run_.cmd()[i];
      approach[i] = run_.approach()[i];
    }
    const models::JointAngles a = head_.Angles(u, approach);
    const auto x = models::PointAtPixel(head_, models::Eye(eye_), a, px, s_.range_m);
    if (!x) return std::nullopt;
    const int servos[2] = {models::kPanServo[eye_], models::kTiltServo[eye_]};
    std::array<int, 2> ap = {approach[servos[0]], approach[servos[1]]};
    auto goal = models::SaccadePulses(head_, models::Eye(eye_), a, *x, pan, tilt, ap, centre);
    if (!goal) return std::nullopt;
    // The approach of this move: toward the goal (or from beyond it when the move is shaped with
    // an overdrive: the first move of a trial); solve again with it (backlash).
    for (int k = 0; k < 2; ++k) {
      const double d = (*goal)[k] - u[servos[k]];
      if (std::abs(d) >= 0.5) ap[k] = (d > 0 ? 1 : -1) * (k == beyond_axis ? -1 : 1);
    }
    return models::SaccadePulses(head_, models::Eye(eye_), a, *x, pan, tilt, ap, centre);
  }

  // The time a plain step of delta_us on axis a (servo i) needs to arrive [s]. Unknown motion:
  // 300 deg/s (the guide's servo at 4.8 V) and 100 ms of lag and slack.
  double MoveTime(int a, int i, double delta_us) const {
    return Known(a) ? std::abs(delta_us) / slew_us_per_s_[a] + 3 * lag_s_[a]
                    : std::abs(delta_us) * std::abs(head_.servo_params[i][1]) / 300.0 + 0.1;
  }
  // The first frame to act on after a move sent at sent_ns that needs move_s: one received at
  // least the exposure delay after the joint arrived (the stream's stamps are arrival times).
  void Expect(int64_t sent_ns, double move_s) {
    ready_ns_ = std::max(ready_ns_, sent_ns + int64_t(std::llround((delay_s_ + move_s) * 1e9)));
  }

  // Whether a first move whose larger part is on axis a (0 pan, 1 tilt) is shaped: asked for,
  // and that servo's slew and lag are known.
  bool Known(int a) const { return slew_us_per_s_[a] > 0 && lag_s_[a] > 0; }
  bool Shaped(int a) const { return s_.shape && Known(a); }

  std::string OutsideMargin(const PwmVector& target) const {
    return models::OutsideMargin(run_.config(), target, s_.limit_margin_us, "stopped before sending", &run_.cmd());
  }

  // Sends the move (shaped when it is the first and the motion is known); returns the time the
  // joint needs to arrive [s].
  // a: the axis that moves more (0 pan, 1 tilt); shaped: overdrive it and switch.
  double Move(const PwmVector& target, int a, bool shaped, bool first, LoopResult* r) {
    const PwmVector from = run_.cmd();
    const int servos[2] = {models::kPanServo[eye_], models::kTiltServo[eye_]};
    const int i = servos[a];
    const double delta = target[i] - from[i];
    double move_s = MoveTime(a, i, delta);
    std::string how = "plain step";
    if (shaped) {
      // Overdrive and switch (models/saccade.h): within 2 % of the step, at least one pulse.
      const double band = std::max(1.0, 0.02 * std::abs(delta));
      const models::SaccadeShape shape = models::ShapeSaccade(delta, slew_us_per_s_[a], lag_s_[a], band);
      int over = int(std::lround(shape.overdrive_us));
      const models::ServoConfig& c = run_.config().servos[i];
      const int sign = delta > 0 ? 1 : -1;
      // Never beyond the limits' margin.
      while (over > 0 && (target[i] + sign * over > c.max_us - s_.limit_margin_us ||
                          target[i] + sign * over < c.min_us + s_.limit_margin_us))
        --over;
      if (over > 0 && shape.switch_s > 0) {
        PwmVector od = target;
        od[i] += sign * over;
        run_.Send(od);
        run_.robot().SleepNs(int64_t(std::llround(shape.switch_s * 1e9)));
        how = "overdrive " + std::to_string(over) + " us for " + FixedText(1000 * shape.switch_s, 0) + " ms";
        move_s = shape.settle_s;
      }
    } else if (first && s_.shape) {
      how = "plain step (no fitted slew and lag to shape it)";
    }
    run_.Send(target);
    if (first)
      r->saccade = std::string(models::kServoNames[i]) + " " + std::to_string(from[i]) + " -> " +
                   std::to_string(target[i]) + " us, " + how;
    return move_s;
  }

  RunContext& run_;
  const SaccadeStep& s_;
  int eye_;
  std::unique_ptr<TargetLocator> loc_;
  models::HeadModel head_;
  std::string map_name_;
  double dead_zone_px_[2] = {1, 1};
  std::array<int, models::kNumServos> pwm_step_us_{};  // 0: unknown
  double slew_us_per_s_[2] = {0, 0}, lag_s_[2] = {0, 0};
  double delay_s_ = kSaccadeDefaultDelayFrames * kDefaultFrameS;
  int64_t ready_ns_ = 0;  // robot clock: frames received before this are not acted on
};

const char* EndName(LoopResult::End e) {
  switch (e) {
    case LoopResult::End::kSettled:
      return "converged";
    case LoopResult::End::kFrames:
      return "ran-all-frames";
    case LoopResult::End::kLost:
      return "target-lost";
    case LoopResult::End::kLimit:
      return "heading-for-limit";
    case LoopResult::End::kFailed:
      return "not-started";
  }
  return "?";
}

// The trial status of a run of the controller on the axes asked for, and why.
calib::TrialStatus Status(const LoopResult& r, bool pan, bool tilt, std::string* reason) {
  reason->clear();
  switch (r.end) {
    case LoopResult::End::kLost:
      *reason = r.message;
      return calib::TrialStatus::kLostTarget;
    case LoopResult::End::kLimit:
      *reason = "stopped before a limit: " + r.message;
      return calib::TrialStatus::kNotSettled;
    case LoopResult::End::kFailed:
      *reason = r.message;
      return calib::TrialStatus::kFailed;
    case LoopResult::End::kSettled:
      return calib::TrialStatus::kOk;
    case LoopResult::End::kFrames:
      break;
  }
  if (!r.found_at_end) {
    *reason = "target not found in the last frame";
    return calib::TrialStatus::kLostTarget;
  }
  const double ex = std::abs(r.final_offset_px.x()), ey = std::abs(r.final_offset_px.y());
  // At the servo's resolution (the map's pulses are the command in force) the controller is done.
  if (!r.at_resolution && ((pan && ex > r.dead_zone_px[0]) || (tilt && ey > r.dead_zone_px[1]))) {
    *reason = "target still " + FixedText(pan ? ex : ey, 2) + " px off (dead zone " +
              FixedText(r.dead_zone_px[pan ? 0 : 1], 2) + " px) after " + std::to_string(r.moves) + " moves";
    return calib::TrialStatus::kNotSettled;
  }
  return calib::TrialStatus::kOk;
}

constexpr const char* kSaccadeTrialColumns =
    "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,"
    "final_offset_px,message,status,reason";

}  // namespace

void RunSaccadeStep(RunContext& run, const Protocol& p, const SaccadeStep& s) {
  const int eye = s.eye;
  const bool pan = s.axis == Axis::kPan;
  const int servo = pan ? models::kPanServo[eye] : models::kTiltServo[eye];
  const models::ServoConfig& sc = run.config().servos[servo];
  SaccadeController ctl(run, p, s);
  run.Event("saccade", "controller on the " + ctl.map_name());
  // The correction's gain on the calibrated map (the gain column of the tables).
  const std::string gain = calib::CsvFixed(1.0, 4);
  SettleRule rest;
  rest.mode = SettleRule::Mode::kTime;
  rest.time_ms = 400;
  int trial_counter = 0;
  const int num = int(s.amplitudes_deg.size()) * s.trials;
  for (double amp : s.amplitudes_deg) {
    for (int trial = 0; trial < s.trials; ++trial, ++trial_counter) {
      run.set_step_work_fraction(double(trial_counter) / std::max(1, num));
      run.CheckStop();
      std::vector<std::string> row = {std::to_string(run.step_index()),
                                      gain,
                                      calib::CsvFixed(amp, 3),
                                      std::to_string(trial),
                                      models::kEyeNames[eye],
                                      AxisName(s.axis),
                                      models::kServoNames[servo]};
      // 1) Fixate with the same controller (both axes).
      const LoopResult a = ctl.Run(true, true, kAcquireFrames, true);
      const PwmVector fix = run.cmd();
      std::string acquire_reason;
      const calib::TrialStatus acquired = Status(a, true, true, &acquire_reason);
      if (acquired != calib::TrialStatus::kOk) {
        const std::string why =
            std::string("no fixation before the step: ") + calib::TrialStatusName(acquired) + ": " + acquire_reason;
        row.insert(row.end(),
                   {"",
                    PwmText(fix),
                    "no-fixation",
                    "0",
                    "",
                    ctl.map_name(),
                    calib::TrialStatusName(calib::TrialStatus::kSkipped),
                    why});
        run.writer().AppendRow("step_trials.csv", kSaccadeTrialColumns, row);
        run.Event("saccade", "trial skipped: " + why);
        if (run.options().progress)
          *run.options().progress << "  saccade " << FixedText(amp, 0) << " deg: skipped (" << why << ")\n";
        continue;
      }
      // 2) Step away by the amplitude (alternating direction), rest.
      const int sign = trial_counter % 2 == 0 ? 1 : -1;
      PwmVector away = fix;
      away[servo] += int(std::lround(sign * amp / sc.nominal_deg_per_us));
      run.Send(away);
      ctl.Moved(servo, away[servo] - fix[servo], run.robot().NowNs());
      run.Settle(rest);
      const PwmVector start = run.cmd();
      // 3) The saccade and its corrections, every frame logged.
      const LoopResult r = ctl.Run(pan, !pan, s.frames, false);
      const int64_t t0 = r.trace.empty() ? 0 : r.trace.front().stamp_ns;
      for (size_t k = 0; k < r.trace.size(); ++k) {
        const Sample& fs = r.trace[k];
        run.writer().AppendRow(
            "step_response.csv",
            "step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index",
            {std::to_string(run.step_index()),
             gain,
             calib::CsvFixed(amp, 3),
             std::to_string(trial),
             std::to_string(k),
             calib::CsvFixed((fs.stamp_ns - t0) * 1e-9, 6),
             fs.found ? calib::CsvFixed(pan ? fs.offset_px.x() : fs.offset_px.y(), 3) : "",
             fs.found ? calib::CsvFixed(pan ? fs.offset_px.y() : fs.offset_px.x(), 3) : "",
             std::to_string(fs.pwm_us[servo]),
             fs.found ? "1" : "0",
             "-1"});  // frames not recorded
      }
      std::string reason;
      const calib::TrialStatus status = Status(r, pan, !pan, &reason);
      const double final_off = pan ? r.final_offset_px.x() : r.final_offset_px.y();
      const std::string message = ctl.map_name() + ": " + (r.saccade.empty() ? "no saccade" : r.saccade) + "; " +
                                  std::to_string(std::max(0, r.moves - 1)) + " corrections; " + r.message;
      row.insert(row.end(),
                 {std::to_string(start[servo]),
                  std::to_string(fix[servo]),
                  EndName(r.end),
                  std::to_string(r.trace.size()),
                  calib::CsvFixed(final_off, 3),
                  message,
                  calib::TrialStatusName(status),
                  reason});
      run.writer().AppendRow("step_trials.csv", kSaccadeTrialColumns, row);
      run.Event("saccade",
                FixedText(amp, 1) + " deg: " + calib::TrialStatusName(status) + " (" + EndName(r.end) + ") " + message);
      if (run.options().progress)
        *run.options().progress << "  saccade " << FixedText(amp, 0) << " deg: " << calib::TrialStatusName(status)
                                << ", final offset " << FixedText(final_off, 2) << " px, " << r.saccade << "\n";
      // 4) Back to the fixation pose.
      const PwmVector back_from = run.cmd();
      run.Send(fix);
      ctl.Moved(servo, fix[servo] - back_from[servo], run.robot().NowNs());
      run.Settle(rest);
    }
  }
}

}  // namespace owlcal::protocols
