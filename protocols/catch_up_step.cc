#include "protocols/catch_up_step.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <optional>

#include "calib/csv.h"
#include "calib/trial_status.h"
#include "models/saccade.h"
#include "models/units.h"
#include "protocols/fixate_step.h"

namespace owlcal::protocols {
namespace {

using models::kNumServos;
using models::PwmVector;
constexpr double kFrameS = 1.0 / 30;
constexpr int kDefaultDelayFrames = 4;
constexpr int kLostFrames = 5;
constexpr int kFixationMoves = 8;
constexpr double kNearEnough = 0.5;      // of the saccade threshold: a fixation not centred to 1 px
constexpr int kVelocityFrames = 6;       // pursuit frames in the target's velocity estimate
constexpr double kFoundFraction = 0.9;   // of a trial's frames, for status ok
constexpr double kEyeSlewDegPerS = 300;  // the move time's slew when the calibration has none (guide, 4.8 V)

constexpr const char* kFrameColumns =
    "step_index,trial,speed_deg_per_s,direction,k,t_s,target_az_deg,cmd_us,found,x_px,error_deg,true_error_deg,"
    "action";
constexpr const char* kTrialColumns =
    "step_index,trial,speed_deg_per_s,direction,frames,found,saccades,map,status,reason";

Eigen::Isometry3d TurnedAboutVertical(const Eigen::Isometry3d& pose, double angle_rad) {
  return Eigen::Isometry3d(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY())) * pose;
}

class CatchUpRun {
 public:
  CatchUpRun(RunContext& run, const Protocol& p, const CatchUpStep& s)
      : run_(run), p_(p), s_(s), eye_(s.eye), loc_(MakeAppearanceCheckedLocator(MakeStepLocator(run, p, s.locator))) {
    const auto& cal = run.options().calibration;
    head_ = cal ? cal->head : models::NominalHeadModel(run.config());
    map_name_ = cal ? "calibrated map (" + cal->source + ")" : std::string("nominal map (robot file: no calibration)");
    const int servo = models::kPanServo[eye_];
    delay_s_ = cal && cal->exposure_delay_s > 0 ? cal->exposure_delay_s : kDefaultDelayFrames * kFrameS;
    slew_deg_per_s_ = cal && cal->slew_us_per_s[servo] > 0
                          ? cal->slew_us_per_s[servo] * std::abs(head_.servo_params[servo][1])
                          : kEyeSlewDegPerS;
    // Unknown motion: 100 ms of lag and slack, as the saccade step.
    settle_s_ = cal && cal->lag_s[servo] > 0 ? 3 * cal->lag_s[servo] : 0.1;
    if (robot::SceneControl* sc = run.robot().Scene()) {
      truth_head_ = sc->TruthHead();
      placed_ = sc->TargetPose(p.target);
    }
  }

  const std::string& map_name() const { return map_name_; }
  bool can_move_target() const { return placed_.has_value(); }

  // The target at azimuth `az_deg` about the base origin (its placed distance and height).
  void PlaceAt(double az_deg) {
    const Eigen::Vector3d c = placed_->translation();
    const double az0 = std::atan2(c.x(), c.z());
    pose_ = TurnedAboutVertical(*placed_, az_deg * kDeg - az0);
    run_.robot().Scene()->SetTargetPose(p_.target, pose_);
  }
  void Restore() {
    if (placed_) run_.robot().Scene()->SetTargetPose(p_.target, *placed_);
  }

  // Centres the target with the maps (both axes of the eye); false and why when it cannot.
  bool Fixate(std::string* why) {
    SettleRule rest;
    rest.mode = SettleRule::Mode::kTime;
    rest.time_ms = 400;
    run_.Settle(rest);
    for (int move = 0; move <= kFixationMoves; ++move) {
      const robot::StereoFrame frame = run_.Grab();
      // A whole-image search at the first move, then tracking; the appearance check rejects what
      // is not the target's first look (the darker image corners, wall blobs) and finds it again.
      if (move == 0 && !loc_->Prepare(frame, why)) return false;
      std::optional<Eigen::Vector2d> px = Locate(frame);
      // A frame exposed while the eye still moved can miss it (variant A: the disc at NCC 0.85).
      for (int retry = 1; !px && retry < kLostFrames; ++retry) px = Locate(run_.Grab());
      if (!px) {
        *why = std::string("target not found in the ") + models::kEyeNames[eye_] + " eye";
        if (const std::string r = loc_->LastReason(eye_); !r.empty()) *why += ": " + r;
        return false;
      }
      const models::JointAngles a = Angles(run_.cmd());
      const auto x = models::PointAtPixel(head_, models::Eye(eye_), a, *px, s_.range_m);
      const auto goal =
          x ? models::SaccadePulses(head_, models::Eye(eye_), a, *x, true, true, {0, 0}, Centre(frame)) : std::nullopt;
      if (!goal) {
        *why = "the map cannot centre the target";
        return false;
      }
      PwmVector target = run_.cmd();
      target[models::kPanServo[eye_]] = int(std::lround((*goal)[0]));
      target[models::kTiltServo[eye_]] = int(std::lround((*goal)[1]));
      if ((*px - Centre(frame)).norm() <= 1.0 || target == run_.cmd()) return true;
      // A servo with a PWM step or dead band cannot put it closer than a step (6.5 px on variant
      // A; the eye settles slowly there): near enough for a pursuit to start from after the last move.
      if (move == kFixationMoves) {
        Eigen::Vector3d ray;
        const Eigen::Vector2d c = Centre(frame);
        Eigen::Vector3d axis;
        if (head_.intrinsics[eye_].Unproject(px->data(), ray.data()) &&
            head_.intrinsics[eye_].Unproject(c.data(), axis.data())) {
          const double off_deg = std::acos(std::clamp(ray.normalized().dot(axis.normalized()), -1.0, 1.0)) / kDeg;
          if (off_deg <= kNearEnough * s_.threshold_deg) return true;
          *why = "the target still " + FixedText(off_deg, 2) + " deg from the image centre after " +
                 std::to_string(kFixationMoves) + " moves of the map";
          return false;
        }
      }
      if (const std::string lim = OutsideMargin(target); !lim.empty()) {
        *why = lim;
        return false;
      }
      run_.Send(target);
      loc_->Expect(eye_, Centre(frame));  // where the move puts it
      run_.Settle(rest);
    }
    *why = "the target not centred within 1 px in " + std::to_string(kFixationMoves) + " moves of the map";
    return false;
  }

  struct Result {
    int frames = 0, found = 0, saccades = 0;
    std::string stopped;  // why the trial stopped early ("" = it ran to the end)
    calib::TrialStatus stop_status = calib::TrialStatus::kOk;
  };

  Result Trial(int trial, double speed, int dir, const std::string& step) {
    Result res;
    const double half = speed * s_.duration_ms / 2000.0;
    const int servo = models::kPanServo[eye_];
    const int64_t t0 = run_.robot().NowNs();
    const int frames = int(std::ceil((s_.duration_ms + s_.hold_ms) / 1000.0 / kFrameS));
    int wait = 0, lost = 0;
    std::deque<std::pair<double, double>> az_seen;  // (exposure time, target azimuth from the frame)
    std::vector<std::pair<int64_t, int>> sent = {{t0 - 1'000'000'000, run_.cmd()[servo]}};
    for (int k = 0; k < frames; ++k) {
      run_.CheckStop();
      const double t = (run_.robot().NowNs() - t0) * 1e-9;
      const double az = -dir * half + dir * speed * std::min(t, s_.duration_ms / 1000.0);
      const bool hidden = s_.hide_after_ms > 0 && t * 1000 >= s_.hide_after_ms;
      PlaceAt(hidden ? az + 180 : az);
      const robot::StereoFrame frame = run_.Grab();
      const double ta = (frame.stamp_ns - t0) * 1e-9;
      // Checked against the target's first look; a lost target is searched for in the whole image.
      const std::optional<Eigen::Vector2d> px = Locate(frame);
      std::optional<double> err, true_err;
      if (px) {
        Eigen::Vector3d ray;
        if (head_.intrinsics[eye_].Unproject(px->data(), ray.data())) err = std::atan2(ray.x(), ray.z()) / kDeg;
      }
      if (robot::SceneControl* sc = run_.robot().Scene())
        if (const auto truth = sc->TruthAnglesForFrame(frame.seq); truth && truth_head_ && !hidden) {
          const Eigen::Vector3d c = truth_head_->PointInCam(models::Eye(eye_), (*truth)[eye_], pose_.translation());
          true_err = std::atan2(c.x(), c.z()) / kDeg;
        }
      ++res.frames;
      std::string action;
      if (err) {
        ++res.found;
        lost = 0;
      }
      // The command in force at this frame's exposure (the map's angles), for the target's
      // azimuth seen from the frame.
      const int64_t exposed_ns = frame.stamp_ns - int64_t(std::llround(delay_s_ * 1e9));
      int cmd_at_exposure = sent.front().second;
      for (const auto& [when, u] : sent)
        if (when <= exposed_ns) cmd_at_exposure = u;
      std::optional<Eigen::Vector3d> x_seen;
      if (px) {
        PwmVector c = run_.cmd();
        c[servo] = cmd_at_exposure;
        x_seen = models::PointAtPixel(head_, models::Eye(eye_), Angles(c), *px, s_.range_m);
      }
      std::string stop;
      if (wait > 0) {
        --wait;
        action = "wait";
      } else if (!err) {
        action = "lost";
        if (++lost >= kLostFrames)
          stop = "target not found in " + std::to_string(lost) +
                 " consecutive frames (last: " + loc_->LastReason(eye_) + ")";
      } else if (k * kFrameS * 1000 > s_.duration_ms + 200 && std::abs(*err) <= s_.threshold_deg) {
        action = "hold";  // the target stopped: pursuit continues but is logged as hold
      }
      if (stop.empty() && err && action != "wait") {
        if (x_seen) {
          az_seen.push_back({ta - delay_s_, std::atan2(x_seen->x(), x_seen->z())});
          while (int(az_seen.size()) > kVelocityFrames) az_seen.pop_front();
        }
        const models::JointAngles a = Angles(run_.cmd());
        const auto x_now = models::PointAtPixel(head_, models::Eye(eye_), a, *px, s_.range_m);
        const bool saccade = std::abs(*err) > s_.threshold_deg;
        std::optional<Eigen::Vector3d> aim = x_now;
        double move_s = 0;
        if (saccade && x_now && x_seen) {
          // Lead the target: its azimuth rate over the last pursuit frames times the time until the
          // eye lands (delay + move).
          double w = 0;
          if (az_seen.size() >= 3) {
            const auto& f = az_seen.front();
            const auto& b = az_seen.back();
            if (b.first > f.first) w = (b.second - f.second) / (b.first - f.first);
          }
          move_s = std::abs(*err) / slew_deg_per_s_ + settle_s_;
          aim = TurnedAboutVertical(Eigen::Isometry3d::Identity(), w * (delay_s_ + move_s)) * *x_now;
        }
        const auto goal =
            aim ? models::SaccadePulses(head_, models::Eye(eye_), a, *aim, true, false, {0, 0}) : std::nullopt;
        if (goal) {
          PwmVector target = run_.cmd();
          const double full = (*goal)[0] - run_.cmd()[servo];
          target[servo] = int(std::lround(run_.cmd()[servo] + (saccade ? full : s_.pursuit_gain * full)));
          bool sent_saccade = false;
          if (target != run_.cmd()) {
            if (const std::string lim = OutsideMargin(target); !lim.empty()) {
              stop = lim;
              res.stop_status = calib::TrialStatus::kNotSettled;
            } else {
              run_.Send(target);
              sent.push_back({run_.robot().NowNs(), target[servo]});
              if (saccade) {
                sent_saccade = true;
                ++res.saccades;
                wait = std::max(0, int(std::ceil((delay_s_ + move_s) / kFrameS - 1e-9)) - 1);
              }
            }
          }
          if (action.empty()) action = sent_saccade ? "saccade" : "pursuit";
        } else if (action.empty()) {
          action = "pursuit";
        }
      }
      run_.writer().AppendRow("catch_up.csv",
                              kFrameColumns,
                              {step,
                               std::to_string(trial),
                               calib::CsvFixed(speed, 3),
                               std::to_string(dir),
                               std::to_string(k),
                               calib::CsvFixed(ta, 6),
                               calib::CsvFixed(az, 4),
                               std::to_string(run_.cmd()[servo]),
                               px ? "1" : "0",
                               px ? calib::CsvFixed(px->x(), 3) : "",
                               err ? calib::CsvFixed(*err, 4) : "",
                               true_err ? calib::CsvFixed(*true_err, 4) : "",
                               action});
      if (!stop.empty()) {
        res.stopped = stop;
        if (res.stop_status == calib::TrialStatus::kOk) res.stop_status = calib::TrialStatus::kLostTarget;
        return res;
      }
    }
    return res;
  }

  std::string OutsideMargin(const PwmVector& target) const {
    return models::OutsideMargin(run_.config(), target, s_.limit_margin_us, "stopped before sending");
  }

 private:
  std::optional<Eigen::Vector2d> Locate(const robot::StereoFrame& f) {
    return loc_->Locate(eye_ == models::kLeftEye ? f.left : f.right, eye_);
  }
  static Eigen::Vector2d Centre(const robot::StereoFrame& f) { return ImageCentre(f.left); }
  models::JointAngles Angles(const PwmVector& c) const { return run_.AnglesAt(head_, c); }

  RunContext& run_;
  const Protocol& p_;
  const CatchUpStep& s_;
  int eye_;
  std::unique_ptr<AppearanceCheckedLocator> loc_;
  models::HeadModel head_;
  std::string map_name_;
  double delay_s_ = 0, slew_deg_per_s_ = kEyeSlewDegPerS, settle_s_ = 0.1;
  std::optional<models::HeadModel> truth_head_;
  std::optional<Eigen::Isometry3d> placed_;
  Eigen::Isometry3d pose_ = Eigen::Isometry3d::Identity();
};

}  // namespace

void RunCatchUpStep(RunContext& run, const Protocol& p, const CatchUpStep& s) {
  CatchUpRun cu(run, p, s);
  const std::string step = std::to_string(run.step_index());
  run.Event("catch-up", "eye on the " + cu.map_name());
  int trial = 0;
  const int total = int(s.speeds_deg_per_s.size());
  for (double speed : s.speeds_deg_per_s) {
    run.set_step_work_fraction(double(trial) / total);
    const int dir = trial % 2 == 0 ? 1 : -1;
    std::vector<std::string> row = {step, std::to_string(trial), calib::CsvFixed(speed, 3), std::to_string(dir)};
    calib::TrialStatus status = calib::TrialStatus::kOk;
    std::string reason;
    CatchUpRun::Result r;
    if (!cu.can_move_target()) {
      status = calib::TrialStatus::kSkipped;
      reason = "the robot cannot move the target (no scene control: a virtual Owl is needed)";
    } else {
      cu.PlaceAt(-dir * speed * s.duration_ms / 2000.0);
      std::string why;
      if (!cu.Fixate(&why)) {
        status = calib::TrialStatus::kSkipped;
        reason = "no fixation before the trial: " + why;
      } else {
        r = cu.Trial(trial, speed, dir, step);
        if (!r.stopped.empty()) {
          status = r.stop_status;
          reason = "stopped after " + std::to_string(r.frames) + " frames: " + r.stopped;
        } else if (r.found < kFoundFraction * r.frames) {
          status = calib::TrialStatus::kLostTarget;
          reason = "target found in " + std::to_string(r.found) + " of " + std::to_string(r.frames) + " frames";
        }
      }
    }
    row.insert(row.end(),
               {std::to_string(r.frames),
                std::to_string(r.found),
                std::to_string(r.saccades),
                cu.map_name(),
                calib::TrialStatusName(status),
                reason});
    run.writer().AppendRow("catch_up_trials.csv", kTrialColumns, row);
    run.Event("catch-up",
              FixedText(speed, 1) + " deg/s: " + calib::TrialStatusName(status) + ", " + std::to_string(r.saccades) +
                  " catch-up saccades" + (reason.empty() ? "" : " (" + reason + ")"));
    if (run.options().progress)
      *run.options().progress << "  catch-up " << FixedText(speed, 1) << " deg/s: " << calib::TrialStatusName(status)
                              << ", " << r.saccades << " catch-up saccades in " << r.frames << " frames\n";
    ++trial;
  }
  cu.Restore();
}

}  // namespace owlcal::protocols
