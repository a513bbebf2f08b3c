#include "protocols/runner.h"

#include <csignal>
#include <filesystem>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "calib/trial_status.h"
#include "calib/observation_io.h"
#include "models/head_model.h"
#include "protocols/coverage.h"
#include "owlcal_version.h"
#include "protocols/fixation.h"
#include "protocols/image_motion.h"
#include "protocols/limits_search.h"
#include "protocols/live_feedback.h"
#include "protocols/step_plan.h"
#include "robot/limits_guard.h"

namespace owlcal::protocols {
namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_stop_signal{0};  // the signal that asked to stop (0: none, or set by a caller)
extern "C" void OnStopSignal(int sig) {
  if (g_stop.load()) std::_Exit(128 + sig);
  g_stop_signal.store(sig);
  g_stop.store(true);
}

std::string StopReason() {
  switch (g_stop_signal.load()) {
    case SIGINT:
      return "stop requested (SIGINT, Ctrl-C)";
    case SIGTERM:
      return "stop requested (SIGTERM)";
    case SIGHUP:
      return "stop requested (SIGHUP: the terminal or SSH session closed)";
    default:
      return "stop requested";
  }
}


using models::kNumServos;
using models::PwmVector;

struct RunAborted : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string F(double v, int prec = 4) {
  std::ostringstream s;
  s << std::setprecision(prec) << std::fixed << v;
  return s.str();
}

std::string PwmText(const PwmVector& p) {
  std::string s;
  for (int i = 0; i < kNumServos; ++i) {
    if (i) s.push_back(' ');
    s.append(std::to_string(p[i]));
  }
  return s;
}

// The eye whose image shows a servo's motion, and the image axis (0 = x, 1 = y).
int ServoEye(int servo) { return servo == models::kLx || servo == models::kLy ? models::kLeftEye : models::kRightEye; }
int ServoAxis(int servo) { return servo == models::kRy || servo == models::kLy ? 1 : 0; }

class Runner {
 public:
  Runner(const std::vector<Protocol>& protocols, robot::RobotInterface& robot, const RunOptions& options)
      : robot_(robot),
        o_(options),
        config_(robot.Config()),
        guard_(robot.Config()) {
    for (const Protocol& p : protocols)
      for (const Step& s : p.steps) steps_.push_back({&p, &s});
    protocols_ = &protocols;
  }

  RunSummary Run();

 private:
  struct FlatStep {
    const Protocol* protocol;
    const Step* step;
  };

  // ---- robot I/O
  void CheckStop() {
    if (o_.stop_flag && o_.stop_flag->load()) throw RunAborted(StopReason());
  }
  void Send(const PwmVector& desired) {
    const robot::ClampResult c = guard_.Clamp(desired);
    if (c.any_clamped) {
      ++summary_.num_clamped;
      const std::string m = "step " + std::to_string(step_index_) + " (" + step_name_ + "): " + c.message;
      if (summary_.clamp_messages.size() < 1000) summary_.clamp_messages.push_back(m);
      Event("clamp", m);
      if (o_.progress && summary_.num_clamped <= 20) *o_.progress << "  CLAMPED " << m << "\n";
    }
    const robot::ServoReply reply = robot_.SendServos(c.pwm_us);
    if (!reply.ok) throw std::runtime_error("servo command " + PwmText(c.pwm_us) + " got no reply from " + robot_.Describe());
    for (int i = 0; i < kNumServos; ++i) {
      if (cmd_known_ && c.pwm_us[i] != cmd_[i]) approach_[i] = c.pwm_us[i] > cmd_[i] ? 1 : -1;
      if (!cmd_known_) approach_[i] = 0;
    }
    cmd_ = c.pwm_us;
    cmd_known_ = true;
  }
  robot::StereoFrame Grab() {
    CheckStop();
    std::optional<robot::StereoFrame> f = robot_.GrabFrame(last_stamp_, o_.frame_timeout_ns);
    if (!f) throw std::runtime_error("no frame from " + robot_.Describe() + " within " + F(o_.frame_timeout_ns * 1e-9, 1) + " s");
    last_stamp_ = f->stamp_ns;
    return std::move(*f);
  }
  int64_t Record(const robot::StereoFrame& f) {
    FrameRecord r;
    r.seq = f.seq;
    r.stamp_ns = f.stamp_ns;
    r.pwm_us = cmd_;
    r.approach = approach_;
    r.step_index = step_index_;
    r.step_name = step_name_;
    r.placement_index = placement_index_;
    int64_t index;
    if (!f.jpeg.empty()) {
      index = writer_->AppendFrame(f.jpeg, r);
    } else {
      cv::Mat sbs;
      cv::hconcat(f.left, f.right, sbs);
      std::vector<uint8_t> jpeg;
      cv::imencode(".jpg", sbs, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95});
      index = writer_->AppendFrame(jpeg, r);
    }
    ++step_frames_;
    if (cur_step_ && cur_step_->detect) Detect(f, index);
    if (o_.on_frame) o_.on_frame(index);
    Progress(false);
    return index;
  }
  void Event(const std::string& kind, const std::string& message) {
    if (writer_) writer_->Event(robot_.NowNs(), kind, message);
  }

  // Detects the protocol's target in both eyes of a recorded frame: observations.csv and the
  // coverage views.
  void Detect(const robot::StereoFrame& f, int64_t index) {
    auto it = cur_protocol_->targets.find(cur_protocol_->target);
    if (it == cur_protocol_->targets.end() || it->second.kind == calib::TargetKind::kFixation) return;
    const calib::TargetDefinition& target = it->second;
    calib::DetectorOptions opt;
    opt.fast_check = true;
    std::vector<calib::CornerObservation> all;
    LiveDetection live;
    for (int e = 0; e < 2; ++e) {
      const cv::Mat& img = e == models::kLeftEye ? f.left : f.right;
      const calib::TargetDetection d = calib::DetectTarget(img, target, opt);
      live.detection[e] = d;
      if (!d.found) continue;
      std::vector<calib::CornerObservation> obs = calib::DetectionToObservations(d, target, int(index), e, cmd_, f.stamp_ns);
      for (auto& o : obs) o.approach = approach_;
      const std::vector<calib::View> views = calib::GroupIntoViews(obs);
      ViewParams vp;
      if (!views.empty() && ComputeViewParams(views[0], target, img.cols, img.rows, &vp)) {
        coverage_views_[e].push_back(vp);
        live.has_view[e] = true;
        live.view[e] = vp;
      }
      all.insert(all.end(), obs.begin(), obs.end());
    }
    if (o_.on_detection) {
      live.left = f.left;
      live.right = f.right;
      live.step_name = step_name_;
      o_.on_detection(live);
    }
    if (!all.empty()) calib::AppendObservationsCsv(writer_->Dir() + "/observations.csv", all);
    detected_any_ = true;
  }
  void WriteCoverage() {
    if (!detected_any_) return;
    for (int e = 0; e < 2; ++e) {
      const Coverage c = ComputeCoverage(coverage_views_[e]);
      std::vector<std::string> row = {models::kEyeNames[e], std::to_string(c.num_views)};
      for (int k = 0; k < 4; ++k) {
        row.push_back(F(c.min[k], 4));
        row.push_back(F(c.max[k], 4));
        row.push_back(F(c.progress[k], 4));
      }
      row.push_back(c.Good() ? "1" : "0");
      writer_->AppendRow("coverage.csv",
                         "eye,num_views,x_min,x_max,x_progress,y_min,y_max,y_progress,size_min,size_max,size_progress,"
                         "skew_min,skew_max,skew_progress,good",
                         row);
      if (o_.progress) *o_.progress << "coverage " << models::kEyeNames[e] << " eye, " << c.num_views << " views:\n" << c.Bars();
    }
  }

  // Waits until the robot settled after the last command; false on a settle timeout.
  bool Settle(const SettleRule& rule) {
    if (rule.mode == SettleRule::Mode::kTime) {
      CheckStop();
      robot_.SleepNs(int64_t(rule.time_ms) * 1'000'000);
      return true;
    }
    const int64_t t0 = robot_.NowNs();
    cv::Mat prev[2];
    int still = 0;
    while (true) {
      const robot::StereoFrame f = Grab();
      cv::Mat cur[2] = {MotionThumb(f.left, 4), MotionThumb(f.right, 4)};
      const int64_t dt = f.stamp_ns - t0;
      if (!prev[0].empty() && dt >= int64_t(rule.min_ms) * 1'000'000) {
        double m = 0;
        for (int e = 0; e < 2; ++e) m = std::max(m, ThumbShift(prev[e], cur[e], 4).px.norm());
        still = m < rule.still_px ? still + 1 : 0;
        if (still >= rule.still_frames) return true;
      }
      if (dt > int64_t(rule.max_ms) * 1'000'000) {
        Event("settle", "step " + std::to_string(step_index_) + ": not settled after " + std::to_string(rule.max_ms) + " ms");
        return false;
      }
      prev[0] = cur[0];
      prev[1] = cur[1];
    }
  }
  void CaptureFrames(int n) {
    for (int i = 0; i < n; ++i) Record(Grab());
  }
  void MoveSettleCapture(const PwmVector& pose, const SettleRule& rule, int frames) {
    Send(pose);
    Settle(rule);
    CaptureFrames(frames);
  }

  // ---- progress
  void Progress(bool force) {
    if (!o_.progress) return;
    const auto now = std::chrono::steady_clock::now();
    const double since = std::chrono::duration<double>(now - last_progress_).count();
    if (!force && since < o_.progress_every_s) return;
    last_progress_ = now;
    const double elapsed = std::chrono::duration<double>(now - wall_start_).count();
    const double frac = total_work_ > 0 ? std::min(1.0, (done_work_ + step_work_fraction_ * current_work_) / total_work_) : 0;
    std::ostringstream s;
    s << "[step " << (step_index_ + 1) << "/" << steps_.size() << " " << step_name_ << "] frames "
      << (writer_ ? writer_->NumFrames() : 0) << ", elapsed " << F(elapsed, 1) << " s";
    if (frac > 0.01) s << ", ETA " << F(elapsed * (1 - frac) / frac, 0) << " s";
    if (summary_.num_clamped) s << ", clamped " << summary_.num_clamped;
    *o_.progress << s.str() << std::endl;
  }

  // ---- steps
  void RunStep(const FlatStep& fs);
  void DoPlace(const Protocol& p, const Step& s);
  void DoFixate(const Protocol& p, const Step& s);
  void DoStepResponse(const Protocol& p, const Step& s);
  void DoLimits(const Step& s);
  void DoAlignment(const Protocol& p, const Step& s);
  void DoLatency(const Step& s);
  std::unique_ptr<TargetLocator> MakeLocator(const Protocol& p, Locator kind);
  FixationResult Fixate(const FixationOptions& fo, TargetLocator& loc, bool record, std::vector<int64_t>* frame_indices);
  FixationOptions FixationFromStep(const Step& s) const;

  robot::RobotInterface& robot_;
  const RunOptions& o_;
  const std::vector<Protocol>* protocols_ = nullptr;
  models::RobotConfig config_;
  robot::LimitsGuard guard_;
  std::vector<FlatStep> steps_;
  std::unique_ptr<DatasetWriter> writer_;
  PwmVector cmd_{};
  bool cmd_known_ = false;
  std::array<int8_t, kNumServos> approach_{};
  int placement_index_ = -1;
  int step_index_ = -1;
  std::string step_name_;
  int64_t last_stamp_ = -1;
  int64_t step_frames_ = 0;
  RunSummary summary_;
  const Step* cur_step_ = nullptr;
  const Protocol* cur_protocol_ = nullptr;
  std::vector<ViewParams> coverage_views_[2];
  bool detected_any_ = false;
  std::chrono::steady_clock::time_point wall_start_, last_progress_;
  double total_work_ = 0, done_work_ = 0, current_work_ = 0, step_work_fraction_ = 0;
};

std::unique_ptr<TargetLocator> Runner::MakeLocator(const Protocol& p, Locator kind) {
  switch (kind) {
    case Locator::kFixation:
      return MakeFixationLocator();
    case Locator::kTemplate:
      return MakeTemplateLocator();
    case Locator::kAprilTag: {
      // The board centre of the protocol's target (its geometry from `targets`).
      auto it = p.targets.find(p.target);
      if (it == p.targets.end() || it->second.kind == calib::TargetKind::kFixation)
        throw std::runtime_error(p.file + ": locator apriltag needs the protocol's target '" + p.target +
                                 "' defined under 'targets' (aprilgrid or chessboard)");
      return MakeBoardLocator(it->second);
    }
  }
  return MakeFixationLocator();
}

FixationOptions Runner::FixationFromStep(const Step& s) const {
  FixationOptions fo;
  fo.gain = s.gain;
  fo.max_iterations = s.max_iterations;
  fo.tolerance_px = s.tolerance_px;
  fo.still_frames = s.still_frames;
  fo.latency_frames = s.latency_frames;
  fo.max_step_us = s.max_step_us;
  fo.limit_margin_us = s.limit_margin_us;
  fo.focal_px = 585.0 * config_.image_width / 640.0;
  fo.eyes[models::kLeftEye] = s.eyes != "right";
  fo.eyes[models::kRightEye] = s.eyes != "left";
  return fo;
}

FixationResult Runner::Fixate(const FixationOptions& fo, TargetLocator& loc, bool record,
                              std::vector<int64_t>* frame_indices) {
  FixationIo io;
  io.command = [this] { return cmd_; };
  io.send = [this](const PwmVector& p) { Send(p); };
  io.grab = [this, record, frame_indices] {
    robot::StereoFrame f = Grab();
    const int64_t index = record ? Record(f) : -1;
    if (frame_indices) frame_indices->push_back(index);
    return f;
  };
  return RunFixation(fo, config_, loc, io);
}

void Runner::DoPlace(const Protocol& p, const Step& s) {
  PlacementRecord rec;
  rec.step_index = step_index_;
  rec.target = s.target;
  rec.distance_m = s.distance_m;
  const calib::TargetDefinition* def = nullptr;
  if (auto it = p.targets.find(s.target); it != p.targets.end()) def = &it->second;
  rec.base_from_target = PlacementPose(s, def);
  robot::SceneControl* scene = robot_.Scene();
  const std::string planned = PlacementPrompt(p, s);
  if (scene) {
    scene->SetTargetPose(s.target, rec.base_from_target);
    if (s.hide_others) {
      for (const std::string& name : scene->TargetNames()) {
        if (name == s.target) continue;
        scene->SetTargetPose(name, HiddenPose());
      }
    }
    rec.source = "scene";
    Event("place", "scene: " + s.target + " at " + F(s.distance_m, 3) + " m");
  } else if (o_.interactive) {
    std::istream& in = o_.input ? *o_.input : std::cin;
    std::ostream& out = o_.progress ? *o_.progress : std::cout;
    out << planned << std::endl;
    std::string answer;
    if (!std::getline(in, answer)) throw RunAborted("no answer to the placement prompt (end of input)");
    rec.source = "prompt";
    rec.answer = answer;
    // A number answers the measured distance in mm.
    try {
      size_t used = 0;
      const double mm = std::stod(answer, &used);
      if (used > 0 && mm > 0) {
        rec.distance_m = mm / 1000.0;
        Step moved = s;
        moved.distance_m = rec.distance_m;
        rec.base_from_target = PlacementPose(moved, def);
      }
    } catch (const std::exception&) {
    }
    Event("place", "prompt: '" + planned + "' answered '" + answer + "'");
  } else {
    rec.source = "file";
    Event("place", "non-interactive, assumed: " + planned);
  }
  rec.stamp_ns = robot_.NowNs();
  placement_index_ = writer_->AppendPlacement(rec);
  robot_.SleepNs(200'000'000);  // frames in flight still show the old scene
}

void Runner::DoFixate(const Protocol& p, const Step& s) {
  if (s.from_centre) {
    Send(config_.Centre());
    Settle(s.settle);
  }
  auto loc = MakeLocator(p, s.locator);
  const FixationOptions fo = FixationFromStep(s);
  const FixationResult r = Fixate(fo, *loc, s.record_frames, nullptr);
  // The settled fixation itself is always recorded (one frame).
  const int64_t frame_index = Record(Grab());
  const PlacementRecord* pl =
      placement_index_ >= 0 && placement_index_ < int(writer_->Placements().size()) ? &writer_->Placements()[placement_index_] : nullptr;
  std::vector<std::string> row = {std::to_string(step_index_),
                                  step_name_,
                                  std::to_string(placement_index_),
                                  pl ? pl->target : "",
                                  pl ? F(pl->distance_m, 6) : "",
                                  s.eyes,
                                  F(s.gain, 4),
                                  OutcomeName(r.outcome),
                                  std::to_string(r.iterations)};
  for (int i = 0; i < kNumServos; ++i) row.push_back(std::to_string(r.final_pwm_us[i]));
  for (int e = 0; e < 2; ++e) {
    row.push_back(r.found[e] ? "1" : "0");
    row.push_back(F(r.residual_px[e].x(), 3));
    row.push_back(F(r.residual_px[e].y(), 3));
  }
  row.push_back(std::to_string(robot_.NowNs()));
  // The approach of the settled command: backlash shifts the eyes by the hysteresis (~0.25 deg
  // each), which ranging must account for (a vergence run moves both eyes outward in turn).
  for (int i = 0; i < kNumServos; ++i) row.push_back(std::to_string(int(approach_[i])));
  // Every fixation is a row with its status (calib/trial_status.h); only "ok" may be ranged.
  std::string reason;
  const calib::TrialStatus status = FixationStatus(r, fo, &reason);
  row.push_back(calib::TrialStatusName(status));
  row.push_back(CsvSafe(reason));
  writer_->AppendRow("fixations.csv",
                     "step_index,step_name,placement_index,target,distance_m,eyes,gain,outcome,iterations,Rx_us,Ry_us,"
                     "Lx_us,Ly_us,Neck_us,left_found,left_dx_px,left_dy_px,right_found,right_dx_px,right_dy_px,stamp_ns,"
                     "approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,status,reason",
                     row);
  Event("fixate", std::string(calib::TrialStatusName(status)) + " (" + OutcomeName(r.outcome) + "): " + r.message +
                      " (frame " + std::to_string(frame_index) + ")");
  if (o_.progress)
    *o_.progress << "  fixate " << s.eyes << " gain " << s.gain << ": " << calib::TrialStatusName(status)
                 << (reason.empty() ? "" : " (" + reason + ")") << " after " << r.iterations
                 << " frames, residual L " << F(r.residual_px[0].norm(), 2) << " px R " << F(r.residual_px[1].norm(), 2)
                 << " px\n";
}

void Runner::DoStepResponse(const Protocol& p, const Step& s) {
  const int eye = s.eye == "left" ? models::kLeftEye : models::kRightEye;
  const int servo = s.axis == "pan" ? models::kPanServo[eye] : models::kTiltServo[eye];
  const models::ServoConfig& sc = config_.servos[servo];
  auto loc = MakeLocator(p, s.locator);
  int trial_counter = 0;
  for (double gain : s.gains) {
    for (double amp : s.amplitudes_deg) {
      for (int trial = 0; trial < s.trials; ++trial, ++trial_counter) {
        // 1) Fixate with a safe, latency-aware loop.
        FixationOptions acquire = FixationFromStep(s);
        acquire.eyes[0] = eye == models::kLeftEye;
        acquire.eyes[1] = eye == models::kRightEye;
        acquire.gain = 0.3;
        acquire.latency_frames = 4;
        acquire.max_iterations = 150;
        acquire.tolerance_px = std::max(1.0, s.tolerance_px);
        const FixationResult a = Fixate(acquire, *loc, false, nullptr);
        const PwmVector fix = cmd_;
        std::vector<std::string> trial_row = {std::to_string(step_index_), F(gain, 4), F(amp, 3), std::to_string(trial),
                                              s.eye, s.axis, models::kServoNames[servo]};
        std::string acquire_reason;
        const calib::TrialStatus acquired = FixationStatus(a, acquire, &acquire_reason);
        if (acquired != calib::TrialStatus::kOk) {
          // The trial is a row too: skipped, saying why.
          const std::string why = std::string("no fixation before the step: ") + calib::TrialStatusName(acquired) + ": " +
                                  acquire_reason;
          trial_row.insert(trial_row.end(), {"", PwmText(fix), "no-fixation", "0", "", CsvSafe(a.message),
                                             calib::TrialStatusName(calib::TrialStatus::kSkipped), CsvSafe(why)});
          writer_->AppendRow("step_trials.csv",
                             "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,"
                             "final_offset_px,message,status,reason",
                             trial_row);
          Event("step-response", "trial skipped: " + why);
          if (o_.progress)
            *o_.progress << "  step " << F(amp, 0) << " deg gain " << F(gain, 3) << ": skipped (" << why << ")\n";
          continue;
        }
        // 2) Step away by the amplitude (alternating direction), settle.
        const int sign = (trial_counter % 2 == 0) ? 1 : -1;
        const int delta = static_cast<int>(std::lround(sign * amp / sc.nominal_deg_per_us));
        PwmVector away = fix;
        away[servo] += delta;
        Send(away);
        SettleRule rest;
        rest.mode = SettleRule::Mode::kTime;
        rest.time_ms = 400;
        Settle(rest);
        const PwmVector start = cmd_;
        // 3) Closed loop for a fixed number of frames, logging every frame.
        FixationOptions fo = FixationFromStep(s);
        fo.eyes[0] = eye == models::kLeftEye;
        fo.eyes[1] = eye == models::kRightEye;
        fo.pan = s.axis == "pan";
        fo.tilt = s.axis == "tilt";
        fo.gain = gain;
        fo.max_iterations = s.frames;
        fo.stop_when_converged = false;
        std::vector<int64_t> frames;
        const FixationResult r = Fixate(fo, *loc, s.record_frames, &frames);
        const int64_t t0 = r.trace.empty() ? 0 : r.trace.front().stamp_ns;
        for (size_t k = 0; k < r.trace.size(); ++k) {
          const FixationSample& fs = r.trace[k];
          const Eigen::Vector2d off = fs.offset_px[eye];
          writer_->AppendRow("step_response.csv",
                             "step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index",
                             {std::to_string(step_index_), F(gain, 4), F(amp, 3), std::to_string(trial), std::to_string(k),
                              F((fs.stamp_ns - t0) * 1e-9, 6), F(s.axis == "pan" ? off.x() : off.y(), 3),
                              F(s.axis == "pan" ? off.y() : off.x(), 3), std::to_string(fs.pwm_us[servo]),
                              fs.found[eye] ? "1" : "0", std::to_string(k < frames.size() ? frames[k] : -1)});
        }
        const double final_off = r.found[eye] ? (s.axis == "pan" ? r.residual_px[eye].x() : r.residual_px[eye].y()) : NAN;
        std::string reason;
        const calib::TrialStatus status = FixationStatus(r, fo, &reason);
        trial_row.insert(trial_row.end(), {std::to_string(start[servo]), std::to_string(fix[servo]), OutcomeName(r.outcome),
                                           std::to_string(r.iterations), F(final_off, 3), CsvSafe(r.message),
                                           calib::TrialStatusName(status), CsvSafe(reason)});
        writer_->AppendRow("step_trials.csv",
                           "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,"
                           "final_offset_px,message,status,reason",
                           trial_row);
        Event("step-response", "gain " + F(gain, 3) + " amplitude " + F(amp, 1) + " deg: " + calib::TrialStatusName(status) +
                                   " (" + OutcomeName(r.outcome) + ") " + r.message);
        if (o_.progress)
          *o_.progress << "  step " << F(amp, 0) << " deg gain " << F(gain, 3) << ": " << calib::TrialStatusName(status)
                       << ", final offset " << F(final_off, 2) << " px\n";
        // 4) Back to the fixation pose.
        Send(fix);
        Settle(rest);
      }
    }
  }
}

void Runner::DoLimits(const Step& s) {
  // protocols/limits_search.h: works with any PWM step and dead band; a black, covered or
  // frozen camera fails the step (after its rows are written), never passes as "configured".
  const double focal_px = 585.0 * config_.image_width / 640.0;
  std::vector<std::string> failed;
  int ends = 0;
  for (int servo : s.servos) {
    const models::ServoConfig& sc = config_.servos[servo];
    const int eye = ServoEye(servo);
    const double px_per_us = sc.nominal_deg_per_us * M_PI / 180.0 * focal_px;
    LimitSearchOptions lo;
    lo.coarse_us = s.coarse_us;
    lo.fine_us = s.fine_us;
    lo.moved_fraction = s.moved_fraction;
    lo.rim_fraction = s.rim_fraction;
    lo.check_rim = servo != models::kNeck;  // the neck carries the sockets with the head
    const PwmVector centre = config_.Centre();
    LimitSearchIo io;
    io.move = [&](int u) {
      PwmVector p = centre;
      p[servo] = u;
      Send(p);
      Settle(s.settle);
    };
    io.image = [&] {
      robot::StereoFrame f = Grab();
      if (s.record_frames) Record(f);
      return (eye == models::kLeftEye ? f.left : f.right).clone();
    };
    for (int d : {+1, -1}) {
      const int limit = d > 0 ? sc.max_us : sc.min_us;
      const std::string end = d > 0 ? "max" : "min";
      ++ends;
      const LimitSearchResult r = SearchLimit(centre[servo], limit, ServoAxis(servo), px_per_us, lo, io);
      const bool ok = r.status == calib::TrialStatus::kOk;
      writer_->AppendRow("limits.csv",
                         "step_index,servo,end,configured_us,measured_us,reason,last_shift_px,rim_darkening,status,message",
                         {std::to_string(step_index_), models::kServoNames[servo], end, std::to_string(limit),
                          ok ? std::to_string(r.measured_us) : "", r.cause, F(r.last_shift_px, 3), F(r.rim, 4),
                          calib::TrialStatusName(r.status), CsvSafe(r.message)});
      const std::string what = std::string(models::kServoNames[servo]) + " " + end;
      if (!ok) failed.push_back(what + ": " + r.message);
      Event("limits", what + ": configured " + std::to_string(limit) + ", " +
                          (ok ? "measured " + std::to_string(r.measured_us) + " (" + r.cause + "): " : "FAILED: ") +
                          r.message);
      if (o_.progress)
        *o_.progress << "  limits " << what << ": configured " << limit << " us, "
                     << (ok ? "measured " + std::to_string(r.measured_us) + " us (" + r.cause + ")" : "FAILED: " + r.message)
                     << "\n";
    }
  }
  Send(config_.Centre());
  Settle(s.settle);
  if (!failed.empty())
    throw std::runtime_error("limits: " + std::to_string(failed.size()) + " of " + std::to_string(ends) +
                             " ends could not be measured (limits.csv names them): " + failed.front() +
                             (failed.size() > 1 ? "; ..." : ""));
}

void Runner::DoAlignment(const Protocol& p, const Step& s) {
  Send(config_.Centre());
  Settle(s.settle);
  const calib::TargetDefinition* def = nullptr;
  if (auto it = p.targets.find(p.target); it != p.targets.end()) def = &it->second;
  for (int i = 0; i < s.frames; ++i) {
    robot::StereoFrame f = Grab();
    const int64_t index = Record(f);
    std::string method = "phase-correlation";
    double roll = NAN, dy = NAN, dx = NAN;
    int corners = 0;
    if (def && def->kind == calib::TargetKind::kChessboard) {
      std::vector<cv::Point2f> c[2];
      bool ok = true;
      for (int e = 0; e < 2 && ok; ++e) {
        cv::Mat grey;
        cv::cvtColor(e == 0 ? f.left : f.right, grey, cv::COLOR_BGR2GRAY);
        ok = cv::findChessboardCorners(grey, cv::Size(def->cols, def->rows), c[e],
                                       cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK);
        if (ok)
          cv::cornerSubPix(grey, c[e], cv::Size(5, 5), cv::Size(-1, -1),
                           cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.01));
      }
      if (ok) {
        method = "chessboard";
        corners = int(c[0].size());
        double ang[2];
        for (int e = 0; e < 2; ++e) {
          // Mean direction of the rows (first -> last corner of each row).
          double sx = 0, sy = 0;
          for (int r = 0; r < def->rows; ++r) {
            const cv::Point2f a = c[e][r * def->cols], b = c[e][r * def->cols + def->cols - 1];
            sx += b.x - a.x;
            sy += b.y - a.y;
          }
          ang[e] = std::atan2(sy, sx) * 180.0 / M_PI;
        }
        roll = ang[0] - ang[1];
        double sdx = 0, sdy = 0;
        for (size_t k = 0; k < c[0].size(); ++k) {
          sdx += c[0][k].x - c[1][k].x;
          sdy += c[0][k].y - c[1][k].y;
        }
        dx = sdx / c[0].size();
        dy = sdy / c[0].size();
      }
    }
    if (method != "chessboard") {
      const Shift sh = ThumbShift(MotionThumb(f.right, 2), MotionThumb(f.left, 2), 2);
      dx = sh.px.x();
      dy = sh.px.y();
    }
    writer_->AppendRow("alignment.csv", "step_index,frame_index,method,roll_deg,vertical_offset_px,horizontal_offset_px,corners",
                       {std::to_string(step_index_), std::to_string(index), method, F(roll, 4), F(dy, 3), F(dx, 3),
                        std::to_string(corners)});
    if (o_.progress && i == 0)
      *o_.progress << "  alignment (" << method << "): roll " << F(roll, 3) << " deg, vertical offset " << F(dy, 2)
                   << " px (left - right)\n";
  }
}

void Runner::DoLatency(const Step& s) {
  const models::ServoConfig& sc = config_.servos[s.servo];
  const int eye = ServoEye(s.servo);
  const int axis = ServoAxis(s.servo);
  const double px_per_us = sc.nominal_deg_per_us * M_PI / 180.0 * 585.0 * config_.image_width / 640.0;
  const double threshold = std::max(1.0, 0.2 * s.amplitude_us * px_per_us);
  PwmVector base = config_.Centre();
  for (int trial = 0; trial < s.trials; ++trial) {
    const int sign = trial % 2 == 0 ? 1 : -1;
    PwmVector from = base, to = base;
    from[s.servo] = base[s.servo] - sign * s.amplitude_us / 2;
    to[s.servo] = base[s.servo] + sign * (s.amplitude_us - s.amplitude_us / 2);
    Send(from);
    Settle(s.settle);
    robot::StereoFrame f0 = Grab();
    const cv::Mat ref = MotionThumb(eye == 0 ? f0.left : f0.right, 2);
    const int64_t t_cmd = robot_.NowNs();
    Send(to);
    double latency_ms = NAN, shift = 0;
    int waited = 0;
    for (; waited < s.max_frames; ++waited) {
      robot::StereoFrame f = Grab();
      if (s.record_frames) Record(f);
      shift = std::abs(ThumbShift(ref, MotionThumb(eye == 0 ? f.left : f.right, 2), 2).px[axis]);
      if (shift > threshold) {
        latency_ms = (f.stamp_ns - t_cmd) * 1e-6;
        break;
      }
    }
    writer_->AppendRow("latency.csv", "step_index,trial,servo,amplitude_us,latency_ms,frames_waited,shift_px",
                       {std::to_string(step_index_), std::to_string(trial), models::kServoNames[s.servo],
                        std::to_string(s.amplitude_us), F(latency_ms, 2), std::to_string(waited + 1), F(shift, 2)});
    if (o_.progress)
      *o_.progress << "  latency trial " << trial << ": " << F(latency_ms, 1) << " ms (" << (waited + 1) << " frames)\n";
  }
}

void Runner::RunStep(const FlatStep& fs) {
  const Step& s = *fs.step;
  const Protocol& p = *fs.protocol;
  switch (s.kind) {
    case StepKind::kMoveTo:
      MoveSettleCapture(s.pose.Resolve(config_), s.settle, s.frames);
      break;
    case StepKind::kSweep:
    case StepKind::kGrid: {
      const std::vector<PlannedPose> poses = PlanPoses(s, config_);
      for (size_t i = 0; i < poses.size(); ++i) {
        step_work_fraction_ = double(i) / poses.size();
        MoveSettleCapture(poses[i].pwm_us, s.settle, poses[i].capture ? s.frames : 0);
      }
      break;
    }
    case StepKind::kPlaceTarget:
      DoPlace(p, s);
      break;
    case StepKind::kCapture:
      Settle(s.settle);
      CaptureFrames(s.frames);
      break;
    case StepKind::kFixate:
      DoFixate(p, s);
      break;
    case StepKind::kStepResponse:
      DoStepResponse(p, s);
      break;
    case StepKind::kLimits:
      DoLimits(s);
      break;
    case StepKind::kAlignment:
      DoAlignment(p, s);
      break;
    case StepKind::kLatency:
      DoLatency(s);
      break;
    case StepKind::kWait:
      CheckStop();
      robot_.SleepNs(int64_t(s.wait_ms) * 1'000'000);
      break;
  }
}

RunSummary Runner::Run() {
  summary_.num_steps = static_cast<int>(steps_.size());
  // Dry run: the plan only, nothing moves.
  if (o_.dry_run) {
    summary_.plan = PlanRun(*protocols_, config_, &summary_.num_clamped);
    summary_.status = "dry-run";
    if (o_.progress)
      for (const std::string& l : summary_.plan) *o_.progress << l << "\n";
    return summary_;
  }
  // Open the dataset.
  int first_step = 0;
  if (o_.resume) {
    writer_ = DatasetWriter::Resume(o_.out_dir);
    const nlohmann::json& m = writer_->Manifest();
    const auto& recorded = m.value("protocols", nlohmann::json::array());
    bool same = recorded.size() == protocols_->size();
    for (size_t i = 0; same && i < protocols_->size(); ++i) same = recorded[i].value("text", "") == (*protocols_)[i].text;
    if (!same) throw std::runtime_error(o_.out_dir + "/manifest.json: field 'protocols': the dataset was recorded with other protocol files; cannot resume");
    std::vector<bool> done(steps_.size(), false);
    for (const StepRecord& r : writer_->Steps())
      if (r.status == "done" && r.step_index >= 0 && r.step_index < int(done.size())) done[r.step_index] = true;
    while (first_step < int(done.size()) && done[first_step]) ++first_step;
    // What the interrupted step recorded is set aside, so the re-run does not count twice.
    writer_->SupersedeFrom(first_step, robot_.NowNs());
    // Coverage continues over the corners detected before the interruption.
    const std::string obs_path = o_.out_dir + "/observations.csv";
    if (std::filesystem::exists(obs_path)) {
      for (const calib::View& v : calib::GroupIntoViews(calib::ReadObservationsCsv(obs_path))) {
        for (const Protocol& p : *protocols_) {
          auto it = p.targets.find(v.target_id);
          if (it == p.targets.end()) continue;
          ViewParams vp;
          if (ComputeViewParams(v, it->second, config_.image_width, config_.image_height, &vp))
            coverage_views_[v.eye == models::kLeftEye ? 0 : 1].push_back(vp);
          detected_any_ = true;
          break;
        }
      }
    }
    writer_->Event(robot_.NowNs(), "resume", "resuming at step " + std::to_string(first_step) + " with " +
                                                 std::to_string(writer_->NumFrames()) + " frames recorded");
    if (o_.progress) *o_.progress << "resuming " << o_.out_dir << " at step " << (first_step + 1) << "/" << steps_.size()
                                  << " (" << writer_->NumFrames() << " frames kept)\n";
  } else {
    nlohmann::json m;
    m["owlcal_version"] = OWLCAL_VERSION;
    m["robot"] = {{"spec", o_.robot_spec},
                  {"description", robot_.Describe()},
                  {"robot_file", o_.robot_file},
                  {"robot_file_text", o_.robot_file_text}};
    nlohmann::json servos = nlohmann::json::array();
    for (const models::ServoConfig& s : config_.servos)
      servos.push_back({{"name", s.name},
                        {"min_us", s.min_us},
                        {"max_us", s.max_us},
                        {"centre_us", s.centre_us},
                        {"direction", s.direction},
                        {"nominal_deg_per_us", s.nominal_deg_per_us}});
    m["robot"]["config"] = {{"name", config_.name},
                            {"servos", servos},
                            {"ipd_m", config_.ipd_m},
                            {"image_width", config_.image_width},
                            {"image_height", config_.image_height},
                            {"swap_eyes", config_.swap_eyes},
                            {"mirror_stream", config_.mirror_stream}};
    m["protocols"] = nlohmann::json::array();
    for (const Protocol& p : *protocols_)
      m["protocols"].push_back({{"file", p.file}, {"name", p.name}, {"target", p.target}, {"text", p.text}});
    m["num_steps"] = steps_.size();
    nlohmann::json steps = nlohmann::json::array();
    for (size_t i = 0; i < steps_.size(); ++i)
      steps.push_back({{"step_index", i}, {"name", steps_[i].step->name}, {"kind", StepKindName(steps_[i].step->kind)},
                       {"protocol", steps_[i].protocol->name}});
    m["steps"] = steps;
    if (!o_.sim.is_null()) {
      m["sim"] = o_.sim;
      if (robot::SceneControl* sc = robot_.Scene()) {
        try {
          m["sim"]["truth_json"] = nlohmann::json::parse(sc->TruthJson());
        } catch (const std::exception&) {
          m["sim"]["truth_text"] = sc->TruthJson();
        }
      }
    }
    writer_ = DatasetWriter::Create(o_.out_dir, m);
  }
  // Work estimate for the ETA.
  std::vector<double> work(steps_.size());
  for (size_t i = 0; i < steps_.size(); ++i) {
    work[i] = StepWork(*steps_[i].step);
    total_work_ += work[i];
    if (int(i) < first_step) done_work_ += work[i];
  }
  wall_start_ = last_progress_ = std::chrono::steady_clock::now();
  const int64_t t_start = robot_.NowNs();
  summary_.steps_done = first_step;
  std::string status = "complete", message;
  try {
    // On resume, restore the placement in force (re-run the last place-target before first_step).
    if (first_step > 0) {
      for (int i = first_step - 1; i >= 0; --i) {
        if (steps_[i].step->kind == StepKind::kPlaceTarget) {
          step_index_ = i;
          step_name_ = steps_[i].step->name;
          DoPlace(*steps_[i].protocol, *steps_[i].step);
          break;
        }
      }
    }
    for (int i = first_step; i < int(steps_.size()); ++i) {
      CheckStop();
      step_index_ = i;
      step_name_ = steps_[i].step->name;
      step_frames_ = 0;
      cur_step_ = steps_[i].step;
      cur_protocol_ = steps_[i].protocol;
      current_work_ = work[i];
      step_work_fraction_ = 0;
      Progress(true);
      const int64_t t0 = robot_.NowNs();
      writer_->Event(t0, "step", "start " + std::to_string(i) + " " + StepKindName(steps_[i].step->kind) + " '" +
                                     step_name_ + "' (" + steps_[i].protocol->name + ")");
      RunStep(steps_[i]);
      writer_->AppendStep({i, step_name_, StepKindName(steps_[i].step->kind), "done", t0, robot_.NowNs(), step_frames_});
      done_work_ += work[i];
      current_work_ = 0;
      summary_.steps_done = i + 1;
    }
    cur_step_ = nullptr;
    WriteCoverage();
  } catch (const RunAborted& e) {
    status = "aborted";
    message = e.what();
  } catch (const std::exception& e) {
    status = "failed";
    message = std::string("step ") + std::to_string(step_index_) + " (" + step_name_ + "): " + e.what();
  }
  // Park at the centre (also after an abort or a failure), then close the dataset.
  try {
    if (cmd_known_ || status != "complete") Send(config_.Centre());
  } catch (const std::exception& e) {
    message += std::string(message.empty() ? "" : "; ") + "parking failed: " + e.what();
    if (status == "complete") status = "failed";
  }
  if (status != "complete" && step_index_ >= 0 && step_index_ < int(steps_.size()))
    writer_->AppendStep({step_index_, step_name_, StepKindName(steps_[step_index_].step->kind), "failed", t_start,
                         robot_.NowNs(), step_frames_});
  writer_->Event(robot_.NowNs(), "finish", status + (message.empty() ? "" : ": " + message));
  writer_->Finish(status, message);
  summary_.status = status;
  summary_.message = message;
  summary_.num_frames = writer_->NumFrames();
  summary_.elapsed_s = (robot_.NowNs() - t_start) * 1e-9;
  if (o_.progress) {
    *o_.progress << "run " << status << ": " << summary_.steps_done << "/" << summary_.num_steps << " steps, "
                 << summary_.num_frames << " frames, " << summary_.num_clamped << " commands clamped, "
                 << F(summary_.elapsed_s, 1) << " s robot time" << (message.empty() ? "" : ": " + message) << "\n";
  }
  return summary_;
}


}  // namespace

bool RunOptions::Check(std::string* why) const {
  if (!dry_run && out_dir.empty()) {
    if (why) *why = "run options: field 'out_dir' is empty (a dataset folder is required unless dry-run)";
    return false;
  }
  if (frame_timeout_ns <= 0) {
    if (why) *why = "run options: field 'frame_timeout_ns' must be > 0";
    return false;
  }
  return true;
}

namespace {
// Throws ProtocolError for the first step whose pulse widths do not fit the robot file.
void CheckProtocolsForRobot(const std::vector<Protocol>& protocols, const models::RobotConfig& robot) {
  for (const Protocol& p : protocols)
    for (const Step& s : p.steps) {
      const std::string why = CheckStepForRobot(s, robot);
      if (!why.empty()) throw ProtocolError(why);
    }
}
}  // namespace

RunSummary RunProtocols(const std::vector<Protocol>& protocols, robot::RobotInterface& robot, const RunOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  CheckProtocolsForRobot(protocols, robot.Config());
  Runner r(protocols, robot, options);
  return r.Run();
}

std::vector<std::string> PlanRun(const std::vector<Protocol>& protocols, const models::RobotConfig& robot,
                                 int64_t* num_clamped) {
  CheckProtocolsForRobot(protocols, robot);
  robot::LimitsGuard guard(robot);
  std::vector<std::string> out;
  int64_t clamped = 0;
  int index = 0;
  auto line = [&](const PwmVector& p, const std::string& what) {
    const robot::ClampResult c = guard.Clamp(p);
    std::string l = "    " + PwmText(p) + "  " + what;
    if (c.any_clamped) {
      ++clamped;
      l += "  CLAMPED -> " + PwmText(c.pwm_us) + " (" + c.message + ")";
    }
    out.push_back(l);
  };
  for (const Protocol& p : protocols) {
    out.push_back("protocol " + p.name + (p.file.empty() ? "" : " (" + p.file + ")") + ", target '" + p.target + "'");
    for (const Step& s : p.steps) {
      out.push_back("  step " + std::to_string(index++) + " " + StepKindName(s.kind) + " '" + s.name + "'");
      switch (s.kind) {
        case StepKind::kMoveTo:
          line(s.pose.Resolve(robot), "move, capture " + std::to_string(s.frames));
          break;
        case StepKind::kSweep:
        case StepKind::kGrid:
          for (const PlannedPose& pp : PlanPoses(s, robot))
            line(pp.pwm_us, pp.capture ? "capture " + std::to_string(s.frames) : "approach");
          break;
        case StepKind::kPlaceTarget:
          out.push_back("    place: " + PlacementPrompt(p, s));
          break;
        case StepKind::kCapture:
          out.push_back("    capture " + std::to_string(s.frames) + " frames");
          break;
        case StepKind::kFixate:
        case StepKind::kStepResponse:
          out.push_back("    closed loop (" + std::string(LocatorName(s.locator)) +
                        "): commands computed at run time, stopped " + std::to_string(s.limit_margin_us) +
                        " us inside every limit");
          break;
        case StepKind::kLimits:
          for (int servo : s.servos) {
            PwmVector c = robot.Centre();
            c[servo] = robot.servos[servo].max_us;
            line(c, std::string("outermost probe ") + models::kServoNames[servo] + " max");
            c[servo] = robot.servos[servo].min_us;
            line(c, std::string("outermost probe ") + models::kServoNames[servo] + " min");
          }
          break;
        case StepKind::kAlignment:
          line(robot.Centre(), "centre, capture " + std::to_string(s.frames));
          break;
        case StepKind::kLatency: {
          PwmVector a = robot.Centre(), b = robot.Centre();
          a[s.servo] -= s.amplitude_us / 2;
          b[s.servo] += s.amplitude_us - s.amplitude_us / 2;
          line(a, "latency step from");
          line(b, "latency step to");
          break;
        }
        case StepKind::kWait:
          out.push_back("    wait " + std::to_string(s.wait_ms) + " ms");
          break;
      }
    }
  }
  out.push_back(std::to_string(clamped) + " planned commands would be clamped to the robot's limits");
  if (num_clamped) *num_clamped = clamped;
  return out;
}

std::atomic<bool>* InstallStopSignals() {
  g_stop.store(false);
  g_stop_signal.store(0);
  std::signal(SIGINT, OnStopSignal);
  std::signal(SIGTERM, OnStopSignal);
  std::signal(SIGHUP, OnStopSignal);
  return &g_stop;
}

}  // namespace owlcal::protocols
