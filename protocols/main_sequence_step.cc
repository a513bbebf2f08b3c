#include "protocols/main_sequence_step.h"

#include <algorithm>
#include <cmath>
#include <optional>

#include <nlohmann/json.hpp>

#include "calib/csv.h"
#include "calib/trial_status.h"
#include "models/joint_solve.h"
#include "models/saccade.h"
#include "models/units.h"
#include "protocols/fixate_step.h"

namespace owlcal::protocols {
namespace {

using models::kNumServos;
using models::PwmVector;
constexpr double kMainSequenceFrameS = 1.0 / 30;  // the Owl's stream (the phase dither's period)
constexpr int kMainSequenceFixationMoves = 8;
constexpr double kFixationTolerancePx = 1.0;
constexpr double kMeasuredFraction = 0.9;  // of a saccade's frames, for status ok
constexpr double kGolden = 0.6180339887498949;

constexpr const char* kMainSequenceFrameColumns =
    "step_index,saccade,amplitude_deg,repeat,direction,eye,servo,k,t_s,cmd_us,found,x_px,y_px,angle_deg,"
    "true_angle_deg";
constexpr const char* kMainSequenceTrialColumns =
    "step_index,saccade,amplitude_deg,repeat,direction,eye,servo,from_us,to_us,map_amplitude_deg,phase_ms,frames,"
    "measured,map,true_slew_deg_per_s,true_lag_s,status,reason";

struct Truth {
  double slew_deg_per_s = NAN, lag_s = NAN;
};

// The servo's true slew and lag from the virtual Owl's truth (robot_truth.servos.<name>).
Truth ServoTruth(robot::RobotInterface& robot, int servo) {
  Truth t;
  robot::SceneControl* sc = robot.Scene();
  if (!sc) return t;
  try {
    const nlohmann::json j = nlohmann::json::parse(sc->TruthJson());
    const nlohmann::json& s = j.at("robot_truth").at("servos").at(models::kServoNames[servo]);
    t.slew_deg_per_s = s.at("slew_deg_per_s").get<double>();
    t.lag_s = s.at("lag_s").get<double>();
  } catch (const std::exception&) {
    // A robot without that truth: the columns stay empty.
  }
  return t;
}

class MainSequenceRun {
 public:
  MainSequenceRun(RunContext& run, const Protocol& p, const MainSequenceStep& s)
      : run_(run), s_(s), eye_(s.eye), loc_(MakeStepLocator(run, p, s.locator)) {
    const auto& cal = run.options().calibration;
    head_ = cal ? cal->head : models::NominalHeadModel(run.config());
    map_name_ = cal ? "calibrated map (" + cal->source + ")" : std::string("nominal map (robot file: no calibration)");
  }

  const std::string& map_name() const { return map_name_; }
  const PwmVector& fixation() const { return fixation_; }

  // Centres the target in the eye with the maps; false (and why) when it cannot.
  bool Fixate(std::string* why) {
    SettleRule rest;
    rest.mode = SettleRule::Mode::kTime;
    rest.time_ms = 400;
    run_.Settle(rest);
    for (int move = 0; move <= kMainSequenceFixationMoves; ++move) {
      const robot::StereoFrame frame = run_.Grab();
      if (!loc_->Prepare(frame, why)) return false;
      const std::optional<Eigen::Vector2d> px = Locate(frame);
      if (!px) {
        *why = std::string("target not found in the ") + models::kEyeNames[eye_] + " eye";
        return false;
      }
      const models::JointAngles a = Angles(run_.cmd());
      const auto x = models::PointAtPixel(head_, models::Eye(eye_), a, *px, s_.range_m);
      if (!x) {
        *why = "the map cannot unproject the target's pixel";
        return false;
      }
      x_in_base_ = *x;
      fix_px_ = *px;
      const auto goal = models::SaccadePulses(head_, models::Eye(eye_), a, *x, true, true, {0, 0}, Centre(frame));
      if (!goal) {
        *why = "the map cannot centre the target";
        return false;
      }
      PwmVector target = run_.cmd();
      target[models::kPanServo[eye_]] = int(std::lround((*goal)[0]));
      target[models::kTiltServo[eye_]] = int(std::lround((*goal)[1]));
      if ((*px - Centre(frame)).norm() <= kFixationTolerancePx || target == run_.cmd() ||
          move == kMainSequenceFixationMoves)
        break;
      if (std::string lim = run_.SendWithinMargin(target, s_.limit_margin_us, "not sent", rest); !lim.empty()) {
        *why = lim;
        return false;
      }
    }
    fixation_ = run_.cmd();
    return true;
  }

  // The map's pulse that turns the pan by `delta_deg` from the fixation, approached from `approach`.
  int PanPulse(double delta_deg, int approach) const {
    const int servo = models::kPanServo[eye_];
    const double q = head_.ServoAngle(servo, fixation_[servo]) + delta_deg * kDeg;
    return int(std::lround(head_.ServoPulse(servo, q, approach)));
  }
  double PanAngleDeg(int pulse_us, int approach) const {
    return head_.ServoAngle(models::kPanServo[eye_], pulse_us, approach) / kDeg;
  }

  std::string OutsideMargin(const PwmVector& target) const {
    return models::OutsideMargin(run_.config(), target, s_.limit_margin_us, "not sent");
  }

  struct FrameRow {
    double t_s = 0;
    int cmd_us = 0;
    bool found = false;
    Eigen::Vector2d px = Eigen::Vector2d::Zero();
    std::optional<double> angle_deg, true_angle_deg;
  };

  // Measures one frame: the target's pixel, the pan angle it implies, the truth.
  FrameRow Measure(const robot::StereoFrame& frame, int64_t t_cmd_ns) {
    FrameRow r;
    r.t_s = (frame.stamp_ns - t_cmd_ns) * 1e-9;
    r.cmd_us = run_.cmd()[models::kPanServo[eye_]];
    std::optional<Eigen::Vector2d> px = Locate(frame);
    if (!px) {  // jumped out of the tracker's window: search the whole image again
      loc_->Prepare(frame, nullptr);
      px = Locate(frame);
    }
    if (px) {
      r.found = true;
      r.px = *px;
      if (const auto q = models::SolveJointForColumn(
              head_, models::Eye(eye_), Angles(run_.cmd()), x_in_base_, px->x(), models::ColumnJoint::kPan))
        r.angle_deg = *q / kDeg;
    }
    if (robot::SceneControl* sc = run_.robot().Scene())
      if (const auto truth = sc->TruthAnglesForFrame(frame.seq)) r.true_angle_deg = (*truth)[eye_].pan_rad[eye_] / kDeg;
    return r;
  }

  std::optional<Eigen::Vector2d> Locate(const robot::StereoFrame& f) {
    return loc_->Locate(eye_ == models::kLeftEye ? f.left : f.right, eye_);
  }
  void Prepare(const robot::StereoFrame& f) { loc_->Prepare(f, nullptr); }

 private:
  static Eigen::Vector2d Centre(const robot::StereoFrame& f) { return ImageCentre(f.left); }
  models::JointAngles Angles(const PwmVector& c) const { return run_.AnglesAt(head_, c); }

  RunContext& run_;
  const MainSequenceStep& s_;
  int eye_;
  std::unique_ptr<TargetLocator> loc_;
  models::HeadModel head_;
  std::string map_name_;
  PwmVector fixation_{};
  Eigen::Vector2d fix_px_ = Eigen::Vector2d::Zero();
  Eigen::Vector3d x_in_base_ = Eigen::Vector3d::Zero();
};

}  // namespace

void RunMainSequenceStep(RunContext& run, const Protocol& p, const MainSequenceStep& s) {
  MainSequenceRun ms(run, p, s);
  const int servo = models::kPanServo[s.eye];
  const std::string step = std::to_string(run.step_index());
  const Truth truth = ServoTruth(run.robot(), servo);
  const std::string true_slew = std::isfinite(truth.slew_deg_per_s) ? calib::CsvFixed(truth.slew_deg_per_s, 3) : "";
  const std::string true_lag = std::isfinite(truth.lag_s) ? calib::CsvFixed(truth.lag_s, 5) : "";
  run.Event("main-sequence", "eye on the " + ms.map_name());
  std::string why;
  const bool fixated = ms.Fixate(&why);
  if (fixated) run.Event("main-sequence", "fixation " + PwmText(ms.fixation()));
  const int total = int(s.amplitudes_deg.size()) * s.repeats;
  int saccade = 0;
  for (double amp : s.amplitudes_deg) {
    for (int rep = 0; rep < s.repeats; ++rep, ++saccade) {
      run.CheckStop();
      run.set_step_work_fraction(double(saccade) / total);
      const int dir = rep % 2 == 0 ? 1 : -1;
      std::vector<std::string> row = {step,
                                      std::to_string(saccade),
                                      calib::CsvFixed(amp, 3),
                                      std::to_string(rep),
                                      std::to_string(dir),
                                      models::kEyeNames[s.eye],
                                      models::kServoNames[servo]};
      auto skipped = [&](const std::string& reason, int from, int to) {
        row.insert(row.end(),
                   {from ? std::to_string(from) : "",
                    to ? std::to_string(to) : "",
                    "",
                    "",
                    "0",
                    "0",
                    ms.map_name(),
                    true_slew,
                    true_lag,
                    calib::TrialStatusName(calib::TrialStatus::kSkipped),
                    reason});
        run.writer().AppendRow("main_sequence_trials.csv", kMainSequenceTrialColumns, row);
        run.Event("main-sequence", FixedText(amp, 1) + " deg, repeat " + std::to_string(rep) + ": skipped: " + reason);
        if (run.options().progress)
          *run.options().progress << "  main sequence " << FixedText(amp, 1) << " deg: skipped (" << reason << ")\n";
      };
      if (!fixated) {
        skipped("no fixation before the saccades: " + why, 0, 0);
        continue;
      }
      const int from_us = ms.PanPulse(-dir * amp / 2, -dir);
      const int to_us = ms.PanPulse(dir * amp / 2, dir);
      PwmVector from = ms.fixation(), to = ms.fixation();
      from[servo] = from_us;
      to[servo] = to_us;
      std::string lim = ms.OutsideMargin(from);
      if (lim.empty()) lim = ms.OutsideMargin(to);
      if (!lim.empty()) {
        skipped(lim, from_us, to_us);
        continue;
      }
      // To the start, rest; then a frame, the phase dither, the command.
      run.Send(from);
      run.robot().SleepNs(int64_t(s.rest_ms) * 1'000'000);
      ms.Prepare(run.Grab());
      const double phase = std::fmod((saccade + 1) * kGolden, 1.0) * kMainSequenceFrameS;
      run.robot().SleepNs(int64_t(std::llround(phase * 1e9)));
      const int64_t t_cmd = run.robot().NowNs();
      run.Send(to);
      int measured = 0;
      for (int k = 0; k < s.frames; ++k) {
        const robot::StereoFrame frame = run.Grab();
        const auto fr = ms.Measure(frame, t_cmd);
        measured += fr.angle_deg ? 1 : 0;
        std::vector<std::string> f = row;
        f.insert(f.end(),
                 {std::to_string(k),
                  calib::CsvFixed(fr.t_s, 6),
                  std::to_string(fr.cmd_us),
                  fr.found ? "1" : "0",
                  fr.found ? calib::CsvFixed(fr.px.x(), 3) : "",
                  fr.found ? calib::CsvFixed(fr.px.y(), 3) : "",
                  fr.angle_deg ? calib::CsvFixed(*fr.angle_deg, 5) : "",
                  fr.true_angle_deg ? calib::CsvFixed(*fr.true_angle_deg, 5) : ""});
        run.writer().AppendRow("main_sequence.csv", kMainSequenceFrameColumns, f);
      }
      calib::TrialStatus status = calib::TrialStatus::kOk;
      std::string reason;
      if (measured < kMeasuredFraction * s.frames) {
        status = calib::TrialStatus::kLostTarget;
        reason = "the eye's angle was measured in " + std::to_string(measured) + " of " + std::to_string(s.frames) +
                 " frames (target not found or its pixel not on the map)";
      }
      row.insert(row.end(),
                 {std::to_string(from_us),
                  std::to_string(to_us),
                  calib::CsvFixed(ms.PanAngleDeg(to_us, dir) - ms.PanAngleDeg(from_us, -dir), 4),
                  calib::CsvFixed(1000 * phase, 3),
                  std::to_string(s.frames),
                  std::to_string(measured),
                  ms.map_name(),
                  true_slew,
                  true_lag,
                  calib::TrialStatusName(status),
                  reason});
      run.writer().AppendRow("main_sequence_trials.csv", kMainSequenceTrialColumns, row);
      if (status != calib::TrialStatus::kOk)
        run.Event("main-sequence",
                  FixedText(amp, 1) + " deg, repeat " + std::to_string(rep) + ": " + calib::TrialStatusName(status) +
                      " (" + reason + ")");
      if (run.options().progress)
        *run.options().progress << "  main sequence " << FixedText(amp, 1) << " deg, repeat " << rep << ": "
                                << calib::TrialStatusName(status) << ", " << measured << " of " << s.frames
                                << " frames measured\n";
    }
  }
  if (fixated) {
    run.Send(ms.fixation());
    run.robot().SleepNs(int64_t(s.rest_ms) * 1'000'000);
  }
}

}  // namespace owlcal::protocols
