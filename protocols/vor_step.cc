#include "protocols/vor_step.h"

#include <algorithm>
#include <cmath>
#include <optional>

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
constexpr double kVorFrameS = 1.0 / 30;  // the Owl's stream
constexpr int kVorFixationMoves = 8;
constexpr double kVorFixationTolerancePx = 1.0;
constexpr double kStepLeadS = 0.5;         // a step profile's rest before the step
constexpr double kVorFoundFraction = 0.9;  // of a trial's frames, per eye, for status ok
constexpr int64_t kRestNs = 600'000'000;

constexpr const char* kVorFrameColumns =
    "step_index,trial,profile,frequency_hz,amplitude_deg,condition,k,t_s,eye,neck_cmd_us,pan_cmd_us,neck_cmd_deg,"
    "pan_cmd_deg,found,x_px,y_px,gaze_err_deg,neck_deg,pan_deg,true_neck_deg,true_pan_deg,true_x_px,true_y_px,"
    "true_gaze_err_deg";
constexpr const char* kVorTrialColumns =
    "step_index,trial,profile,frequency_hz,amplitude_deg,condition,frames,found_left,found_right,map,message,status,"
    "reason";

struct Profile {
  bool sine = true;
  double hz = 0;  // sine
  double amplitude_deg = 0;
  double duration_s = 0;
  double hold_s = 0;  // step
  // The neck's turn from the fixation pose at time t [rad].
  double At(double t) const {
    if (sine) return t < duration_s ? amplitude_deg * kDeg * std::sin(2 * M_PI * hz * t) : 0.0;
    return t >= kStepLeadS && t < kStepLeadS + hold_s ? amplitude_deg * kDeg : 0.0;
  }
  std::string Name() const { return sine ? "sine" : "step"; }
};

// One eye's sample of one frame.
struct EyeSample {
  bool found = false;
  Eigen::Vector2d px = Eigen::Vector2d::Zero();
  std::optional<double> gaze_err_deg, neck_deg, pan_deg;
  std::optional<double> true_neck_deg, true_pan_deg, true_gaze_err_deg;
  std::optional<Eigen::Vector2d> true_px;
};

struct FrameSample {
  double t_s = 0;
  PwmVector cmd{};
  std::array<int8_t, kNumServos> approach{};  // of each servo's last move (backlash)
  EyeSample eye[2];
};

std::string Cell(const std::optional<double>& v, int decimals) { return v ? calib::CsvFixed(*v, decimals) : ""; }

class VorRun {
 public:
  VorRun(RunContext& run, const Protocol& p, const VorStep& s)
      : run_(run), s_(s), loc_(MakeStepLocator(run, p, s.locator)) {
    const auto& cal = run.options().calibration;
    head_ = cal ? cal->head : models::NominalHeadModel(run.config());
    map_name_ = cal ? "calibrated map (" + cal->source + ")" : std::string("nominal map (robot file: no calibration)");
    if (robot::SceneControl* sc = run.robot().Scene()) {
      truth_head_ = sc->TruthHead();
      if (const auto pose = sc->TargetPose(p.target)) target_in_base_ = pose->translation();
    }
  }

  const std::string& map_name() const { return map_name_; }

  // Centres the target in both eyes with the maps; false (and why) when it cannot.
  bool Fixate(std::string* why) {
    SettleRule rest;
    rest.mode = SettleRule::Mode::kTime;
    rest.time_ms = 400;
    run_.Settle(rest);
    for (int move = 0; move <= kVorFixationMoves; ++move) {
      const robot::StereoFrame frame = run_.Grab();
      if (!loc_->Prepare(frame, why)) return false;
      PwmVector target = run_.cmd();
      bool all_within = true;
      for (int e = 0; e < 2; ++e) {
        const std::optional<Eigen::Vector2d> px = Locate(frame, e);
        if (!px) {
          *why = std::string("target not found in the ") + models::kEyeNames[e] + " eye";
          return false;
        }
        fix_px_[e] = *px;
        const models::JointAngles a = Angles(run_.cmd());
        const auto x = models::PointAtPixel(head_, models::Eye(e), a, *px, s_.range_m);
        if (!x) {
          *why = std::string("the map cannot unproject the ") + models::kEyeNames[e] + " eye's pixel";
          return false;
        }
        x_in_base_[e] = *x;
        if ((*px - Centre(frame)).norm() > kVorFixationTolerancePx) all_within = false;
        const auto goal = models::SaccadePulses(head_, models::Eye(e), a, *x, true, true, {0, 0}, Centre(frame));
        if (!goal) {
          *why = std::string("the map cannot centre the target in the ") + models::kEyeNames[e] + " eye";
          return false;
        }
        target[models::kPanServo[e]] = int(std::lround((*goal)[0]));
        target[models::kTiltServo[e]] = int(std::lround((*goal)[1]));
      }
      if (all_within || target == run_.cmd() || move == kVorFixationMoves) {
        fixation_ = run_.cmd();
        return true;
      }
      if (std::string lim = run_.SendWithinMargin(target, s_.limit_margin_us, "stopped before sending", rest);
          !lim.empty()) {
        *why = lim;
        return false;
      }
    }
    fixation_ = run_.cmd();
    return true;
  }

  // One trial; fills `samples`. Returns "" or why it stopped early (a limit).
  std::string Trial(const Profile& prof,
                    bool vor,
                    const std::vector<FrameSample>* still,
                    std::vector<FrameSample>* out) {
    out->clear();
    run_.Send(fixation_);
    run_.robot().SleepNs(kRestNs);
    const robot::StereoFrame sync = run_.Grab();
    loc_->Prepare(sync, nullptr);
    const int64_t t0 = run_.robot().NowNs();
    const double neck0 = head_.ServoAngle(models::kNeck, fixation_[models::kNeck]);
    const double total_s = prof.sine ? prof.duration_s : kStepLeadS + 2 * prof.hold_s;
    const int frames = int(std::ceil(total_s / kVorFrameS));
    for (int k = 0; k < frames; ++k) {
      run_.CheckStop();
      const double t = (run_.robot().NowNs() - t0) * 1e-9;
      PwmVector cmd = fixation_;
      cmd[models::kNeck] = int(std::lround(head_.ServoPulse(models::kNeck, neck0 + prof.At(t))));
      if (vor) {
        models::JointAngles a = Angles(cmd);
        for (int e = 0; e < 2; ++e) {
          const int servo = models::kPanServo[e];
          // Solve for the pulse, then again with the approach of this move (backlash).
          auto goal = models::SaccadePulses(head_, models::Eye(e), a, x_in_base_[e], true, false, {0, 0}, fix_px_[e]);
          if (goal) {
            const double d = (*goal)[0] - run_.cmd()[servo];
            const int ap = std::abs(d) >= 0.5 ? (d > 0 ? 1 : -1) : run_.approach()[servo];
            goal = models::SaccadePulses(head_, models::Eye(e), a, x_in_base_[e], true, false, {ap, 0}, fix_px_[e]);
          }
          if (!goal) return std::string("the map cannot keep the target in the ") + models::kEyeNames[e] + " eye";
          cmd[servo] = int(std::lround((*goal)[0]));
        }
      }
      if (const std::string lim = OutsideMargin(cmd); !lim.empty()) return lim;
      run_.Send(cmd);
      const robot::StereoFrame frame = run_.Grab();
      FrameSample fs;
      fs.t_s = (frame.stamp_ns - t0) * 1e-9;
      fs.cmd = run_.cmd();
      fs.approach = run_.approach();
      const models::JointAngles a = Angles(fs.cmd);
      std::optional<std::array<models::JointAngles, 2>> truth;
      if (robot::SceneControl* sc = run_.robot().Scene()) truth = sc->TruthAnglesForFrame(frame.seq);
      for (int e = 0; e < 2; ++e) {
        EyeSample& es = fs.eye[e];
        const models::Eye eye = models::Eye(e);
        std::optional<Eigen::Vector2d> px = Locate(frame, e);
        if (!px) {  // jumped out of the tracker's window: search the whole image again
          loc_->Prepare(frame, nullptr);
          px = Locate(frame, e);
        }
        if (px) {
          es.found = true;
          es.px = *px;
          Eigen::Vector3d ray;
          if (head_.intrinsics[e].Unproject(px->data(), ray.data()))
            es.gaze_err_deg = std::atan2(ray.x(), ray.z()) / kDeg;
          if (!vor) {
            if (auto n = models::SolveJointForColumn(head_, eye, a, x_in_base_[e], px->x(), models::ColumnJoint::kNeck))
              es.neck_deg = *n / kDeg;
            es.pan_deg = a.pan_rad[e] / kDeg;
          } else if (still && k < int(still->size())) {
            if (const std::optional<double> n = NeckOf((*still)[k])) {
              models::JointAngles b = a;
              b.neck_rad = *n * kDeg;
              es.neck_deg = *n;
              if (auto q =
                      models::SolveJointForColumn(head_, eye, b, x_in_base_[e], px->x(), models::ColumnJoint::kPan))
                es.pan_deg = *q / kDeg;
            }
          }
        }
        if (truth) {
          const models::JointAngles& ta = (*truth)[e];
          es.true_neck_deg = ta.neck_rad / kDeg;
          es.true_pan_deg = ta.pan_rad[e] / kDeg;
          if (truth_head_ && target_in_base_) {
            Eigen::Vector2d tp;
            if (truth_head_->Project(eye, ta, *target_in_base_, &tp)) es.true_px = tp;
            const Eigen::Vector3d c = truth_head_->PointInCam(eye, ta, *target_in_base_);
            es.true_gaze_err_deg = std::atan2(c.x(), c.z()) / kDeg;
          }
        }
      }
      out->push_back(fs);
    }
    return "";
  }

  // Back to the fixation pose.
  void Park() {
    run_.Send(fixation_);
    run_.robot().SleepNs(kRestNs);
  }

  const PwmVector& fixation() const { return fixation_; }
  // The map's angle of a logged command, with the approach of each servo's last move.
  double NeckCmdDeg(const FrameSample& f) const {
    return head_.ServoAngle(models::kNeck, f.cmd[models::kNeck], f.approach[models::kNeck]) / kDeg;
  }
  double PanCmdDeg(const FrameSample& f, int e) const {
    const int i = models::kPanServo[e];
    return head_.ServoAngle(i, f.cmd[i], f.approach[i]) / kDeg;
  }

  // The neck angle a "still" frame measured: the mean over the eyes that measured it.
  static std::optional<double> NeckOf(const FrameSample& f) {
    double sum = 0;
    int n = 0;
    for (const EyeSample& e : f.eye)
      if (e.neck_deg) {
        sum += *e.neck_deg;
        ++n;
      }
    if (n == 0) return std::nullopt;
    return sum / n;
  }

 private:
  std::optional<Eigen::Vector2d> Locate(const robot::StereoFrame& f, int e) {
    return loc_->Locate(e == models::kLeftEye ? f.left : f.right, e);
  }
  static Eigen::Vector2d Centre(const robot::StereoFrame& f) { return ImageCentre(f.left); }
  models::JointAngles Angles(const PwmVector& c) const { return run_.AnglesAt(head_, c); }
  std::string OutsideMargin(const PwmVector& target) const {
    return models::OutsideMargin(run_.config(), target, s_.limit_margin_us, "stopped before sending");
  }

  RunContext& run_;
  const VorStep& s_;
  std::unique_ptr<TargetLocator> loc_;
  models::HeadModel head_;
  std::string map_name_;
  std::optional<models::HeadModel> truth_head_;
  std::optional<Eigen::Vector3d> target_in_base_;
  PwmVector fixation_{};
  Eigen::Vector2d fix_px_[2];
  Eigen::Vector3d x_in_base_[2];
};

}  // namespace

void RunVorStep(RunContext& run, const Protocol& p, const VorStep& s) {
  VorRun vr(run, p, s);
  run.Event("vor", "eyes on the " + vr.map_name());
  std::vector<Profile> profiles;
  for (double hz : s.sines_hz) {
    Profile pr;
    pr.hz = hz;
    pr.amplitude_deg = s.amplitude_deg;
    pr.duration_s = s.cycles / hz;
    profiles.push_back(pr);
  }
  for (double a : s.steps_deg) {
    Profile pr;
    pr.sine = false;
    pr.amplitude_deg = a;
    pr.hold_s = s.hold_ms / 1000.0;
    profiles.push_back(pr);
  }
  const std::string step = std::to_string(run.step_index());
  auto trial_row = [&](int trial, const Profile& pr, const char* condition) {
    return std::vector<std::string>{step,
                                    std::to_string(trial),
                                    pr.Name(),
                                    pr.sine ? calib::CsvFixed(pr.hz, 3) : "",
                                    calib::CsvFixed(pr.amplitude_deg, 3),
                                    condition};
  };
  std::string why;
  if (!vr.Fixate(&why)) {
    int trial = 0;
    for (const Profile& pr : profiles)
      for (const char* condition : {"still", "vor"}) {
        std::vector<std::string> row = trial_row(trial++, pr, condition);
        row.insert(row.end(),
                   {"0",
                    "0",
                    "0",
                    vr.map_name(),
                    "",
                    calib::TrialStatusName(calib::TrialStatus::kSkipped),
                    "no fixation before the trial: " + why});
        run.writer().AppendRow("vor_trials.csv", kVorTrialColumns, row);
      }
    run.Event("vor", "skipped: no fixation: " + why);
    if (run.options().progress) *run.options().progress << "  vor: skipped (no fixation: " << why << ")\n";
    return;
  }
  run.Event("vor", "fixation " + PwmText(vr.fixation()));
  int trial = 0;
  std::vector<FrameSample> still, moving;
  for (size_t pi = 0; pi < profiles.size(); ++pi) {
    const Profile& pr = profiles[pi];
    for (const bool vor : {false, true}) {
      run.set_step_work_fraction(double(2 * pi + (vor ? 1 : 0)) / (2 * profiles.size()));
      const char* condition = vor ? "vor" : "still";
      std::vector<FrameSample>& samples = vor ? moving : still;
      const std::string stopped = vr.Trial(pr, vor, vor ? &still : nullptr, &samples);
      int found[2] = {0, 0};
      for (size_t k = 0; k < samples.size(); ++k) {
        const FrameSample& f = samples[k];
        for (int e = 0; e < 2; ++e) {
          const EyeSample& es = f.eye[e];
          found[e] += es.found ? 1 : 0;
          std::vector<std::string> row = trial_row(trial, pr, condition);
          row.insert(row.end(),
                     {std::to_string(k),
                      calib::CsvFixed(f.t_s, 6),
                      models::kEyeNames[e],
                      std::to_string(f.cmd[models::kNeck]),
                      std::to_string(f.cmd[models::kPanServo[e]]),
                      calib::CsvFixed(vr.NeckCmdDeg(f), 4),
                      calib::CsvFixed(vr.PanCmdDeg(f, e), 4),
                      es.found ? "1" : "0",
                      es.found ? calib::CsvFixed(es.px.x(), 3) : "",
                      es.found ? calib::CsvFixed(es.px.y(), 3) : "",
                      Cell(es.gaze_err_deg, 4),
                      Cell(es.neck_deg, 4),
                      Cell(es.pan_deg, 4),
                      Cell(es.true_neck_deg, 4),
                      Cell(es.true_pan_deg, 4),
                      es.true_px ? calib::CsvFixed(es.true_px->x(), 3) : "",
                      es.true_px ? calib::CsvFixed(es.true_px->y(), 3) : "",
                      Cell(es.true_gaze_err_deg, 4)});
          run.writer().AppendRow("vor.csv", kVorFrameColumns, row);
        }
      }
      const int n = int(samples.size());
      calib::TrialStatus status = calib::TrialStatus::kOk;
      std::string reason;
      if (!stopped.empty()) {
        status = calib::TrialStatus::kNotSettled;
        reason = "stopped before a limit after " + std::to_string(n) + " frames: " + stopped;
      } else {
        for (int e = 0; e < 2; ++e)
          if (found[e] < kVorFoundFraction * n) {
            status = calib::TrialStatus::kLostTarget;
            reason += std::string(reason.empty() ? "" : "; ") + "target found in " + std::to_string(found[e]) + " of " +
                      std::to_string(n) + " frames of the " + models::kEyeNames[e] + " eye";
          }
      }
      const std::string message = pr.Name() + " " + FixedText(pr.amplitude_deg, 1) + " deg" +
                                  (pr.sine ? " at " + FixedText(pr.hz, 2) + " Hz" : "") + ", eyes " +
                                  (vor ? "counter-rotating" : "held still");
      std::vector<std::string> row = trial_row(trial, pr, condition);
      row.insert(row.end(),
                 {std::to_string(n),
                  std::to_string(found[0]),
                  std::to_string(found[1]),
                  vr.map_name(),
                  message,
                  calib::TrialStatusName(status),
                  reason});
      run.writer().AppendRow("vor_trials.csv", kVorTrialColumns, row);
      run.Event("vor", message + ": " + calib::TrialStatusName(status) + (reason.empty() ? "" : " (" + reason + ")"));
      if (run.options().progress)
        *run.options().progress << "  vor " << message << ": " << calib::TrialStatusName(status) << ", " << n
                                << " frames\n";
      ++trial;
    }
  }
  vr.Park();
}

}  // namespace owlcal::protocols
