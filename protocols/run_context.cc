#include "protocols/run_context.h"

#include <algorithm>
#include <iomanip>
#include <sstream>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "calib/observation_io.h"
#include "protocols/image_motion.h"
#include "protocols/live_feedback.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

std::string PwmText(const PwmVector& p) {
  std::string s;
  for (int i = 0; i < kNumServos; ++i) {
    if (i) s.push_back(' ');
    s.append(std::to_string(p[i]));
  }
  return s;
}

int ServoEye(int servo) { return servo == models::kLx || servo == models::kLy ? models::kLeftEye : models::kRightEye; }
int ServoAxis(int servo) { return servo == models::kRy || servo == models::kLy ? 1 : 0; }

RunContext::RunContext(robot::RobotInterface& robot, const RunOptions& options)
    : robot_(robot), o_(options), config_(robot.Config()), guard_(robot.Config()) {}

void RunContext::CheckStop() {
  if (o_.stop_flag && o_.stop_flag->load()) throw RunAborted(StopReason());
}

void RunContext::Send(const PwmVector& desired) {
  const robot::ClampResult c = guard_.Clamp(desired);
  if (c.any_clamped) {
    ++summary_.num_clamped;
    const std::string m = "step " + std::to_string(step_index_) + " (" + step_name_ + "): " + c.message;
    if (summary_.clamp_messages.size() < 1000) summary_.clamp_messages.push_back(m);
    Event("clamp", m);
    if (o_.progress && summary_.num_clamped <= 20) *o_.progress << "  CLAMPED " << m << "\n";
  }
  const robot::ServoReply reply = robot_.SendServos(c.pwm_us);
  if (!reply.ok)
    throw std::runtime_error("servo command " + PwmText(c.pwm_us) + " got no reply from " + robot_.Describe());
  for (int i = 0; i < kNumServos; ++i) {
    if (cmd_known_ && c.pwm_us[i] != cmd_[i]) approach_[i] = c.pwm_us[i] > cmd_[i] ? 1 : -1;
    if (!cmd_known_) approach_[i] = 0;
  }
  cmd_ = c.pwm_us;
  cmd_known_ = true;
}

std::string RunContext::SendWithinMargin(const PwmVector& target,
                                         int margin_us,
                                         const std::string& what,
                                         const SettleRule& rule) {
  std::string why = models::OutsideMargin(config(), target, margin_us, what);
  if (!why.empty()) return why;
  Send(target);
  Settle(rule);
  return "";
}

robot::StereoFrame RunContext::Grab() {
  CheckStop();
  std::optional<robot::StereoFrame> f = robot_.GrabFrame(last_stamp_, o_.frame_timeout_ns);
  if (!f)
    throw std::runtime_error("no frame from " + robot_.Describe() + " within " +
                             FixedText(o_.frame_timeout_ns * 1e-9, 1) + " s");
  last_stamp_ = f->stamp_ns;
  return std::move(*f);
}

int64_t RunContext::Record(const robot::StereoFrame& f) {
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
  if (cur_step_ && cur_step_->Detects()) Detect(f, index);
  if (o_.on_frame) o_.on_frame(index);
  Progress(false);
  return index;
}

void RunContext::Event(const std::string& kind, const std::string& message) {
  if (writer_) writer_->Event(robot_.NowNs(), kind, message);
}

void RunContext::Detect(const robot::StereoFrame& f, int64_t index) {
  auto it = cur_protocol_->targets.find(cur_protocol_->target);
  if (it == cur_protocol_->targets.end() || it->second.kind == calib::TargetKind::kFixation) return;
  const calib::TargetDefinition& target = it->second;
  calib::DetectorOptions opt;
  opt.fast_check = true;
  std::vector<calib::CornerObservation> all;
  LiveDetection live;
  // The tag grids around the scene (tag_targets): every grid tag fully in the image counts, so
  // they are seen where the board has left the view or is cut by the socket rim; libapriltag
  // runs once per image for all of them.
  std::vector<calib::TargetDefinition> grids;
  if (cur_step_->DetectsTags())
    for (const std::string& name : cur_protocol_->tag_targets)
      if (const auto t = cur_protocol_->targets.find(name); t != cur_protocol_->targets.end())
        grids.push_back(t->second);
  std::vector<calib::TargetDetection> tags[2];
  // The two eyes are detected at once (the detector has no shared state), then used in eye order.
  cv::parallel_for_(cv::Range(0, 2), [&](const cv::Range& eyes) {
    for (int e = eyes.start; e < eyes.end; ++e) {
      const cv::Mat& img = e == models::kLeftEye ? f.left : f.right;
      live.detection[e] = calib::DetectTarget(img, target, opt);
      if (!grids.empty()) tags[e] = calib::DetectAprilGrids(img, grids, calib::DetectorOptions());
    }
  });
  for (int e = 0; e < 2; ++e) {
    const cv::Mat& img = e == models::kLeftEye ? f.left : f.right;
    const calib::TargetDetection& d = live.detection[e];
    if (!d.found) continue;
    std::vector<calib::CornerObservation> obs =
        calib::DetectionToObservations(d, target, int(index), e, cmd_, f.stamp_ns);
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
  for (int e = 0; e < 2; ++e)
    for (size_t g = 0; g < tags[e].size(); ++g) {
      std::vector<calib::CornerObservation> obs =
          calib::DetectionToObservations(tags[e][g], grids[g], int(index), e, cmd_, f.stamp_ns);
      for (auto& o : obs) o.approach = approach_;
      all.insert(all.end(), obs.begin(), obs.end());
    }
  if (!all.empty()) calib::AppendObservationsCsv(writer_->Dir() + "/observations.csv", all);
  detected_any_ = true;
}

void RunContext::WriteCoverage() {
  if (!detected_any_) return;
  for (int e = 0; e < 2; ++e) {
    const Coverage c = ComputeCoverage(coverage_views_[e]);
    std::vector<std::string> row = {models::kEyeNames[e], std::to_string(c.num_views)};
    for (int k = 0; k < 4; ++k) {
      row.push_back(calib::CsvFixed(c.min[k], 4));
      row.push_back(calib::CsvFixed(c.max[k], 4));
      row.push_back(calib::CsvFixed(c.progress[k], 4));
    }
    row.push_back(c.Good() ? "1" : "0");
    writer_->AppendRow("coverage.csv",
                       "eye,num_views,x_min,x_max,x_progress,y_min,y_max,y_progress,size_min,size_max,size_progress,"
                       "skew_min,skew_max,skew_progress,good",
                       row);
    if (o_.progress)
      *o_.progress << "coverage " << models::kEyeNames[e] << " eye, " << c.num_views << " views:\n" << c.Bars();
  }
}

bool RunContext::Settle(const SettleRule& rule) {
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
      Event("settle",
            "step " + std::to_string(step_index_) + ": not settled after " + std::to_string(rule.max_ms) + " ms");
      return false;
    }
    prev[0] = cur[0];
    prev[1] = cur[1];
  }
}

void RunContext::CaptureFrames(int n) {
  for (int i = 0; i < n; ++i) Record(Grab());
}

void RunContext::MoveSettleCapture(const PwmVector& pose, const SettleRule& rule, int frames) {
  Send(pose);
  Settle(rule);
  CaptureFrames(frames);
}

FixationResult RunContext::Fixate(const FixationOptions& fo,
                                  TargetLocator& loc,
                                  bool record,
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

void RunContext::Progress(bool force) {
  if (!o_.progress) return;
  const auto now = std::chrono::steady_clock::now();
  const double since = std::chrono::duration<double>(now - last_progress_).count();
  if (!force && since < o_.progress_every_s) return;
  last_progress_ = now;
  const double elapsed = std::chrono::duration<double>(now - wall_start_).count();
  const double frac =
      total_work_ > 0 ? std::min(1.0, (done_work_ + step_work_fraction_ * current_work_) / total_work_) : 0;
  std::ostringstream s;
  s << "[step " << (step_index_ + 1) << "/" << num_steps_ << " " << step_name_ << "] frames "
    << (writer_ ? writer_->NumFrames() : 0) << ", elapsed " << FixedText(elapsed, 1) << " s";
  if (frac > 0.01) s << ", ETA " << FixedText(elapsed * (1 - frac) / frac, 0) << " s";
  if (summary_.num_clamped) s << ", clamped " << summary_.num_clamped;
  *o_.progress << s.str() << std::endl;
}

}  // namespace owlcal::protocols
