#include "protocols/runner.h"

#include <chrono>
#include <csignal>
#include <filesystem>
#include <stdexcept>

#include "calib/observation_io.h"
#include "protocols/alignment_step.h"
#include "protocols/catch_up_step.h"
#include "protocols/fixate_step.h"
#include "protocols/latency_step.h"
#include "protocols/limits_step.h"
#include "protocols/main_sequence_step.h"
#include "protocols/placement_step.h"
#include "protocols/run_context.h"
#include "protocols/run_manifest.h"
#include "protocols/run_plan.h"
#include "protocols/saccade_step.h"
#include "protocols/step_plan.h"
#include "protocols/step_response_step.h"
#include "protocols/track_step.h"
#include "protocols/vor_step.h"

namespace owlcal::protocols {
namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_stop_signal{0};  // the signal that asked to stop (0: none, or set by a caller)
extern "C" void OnStopSignal(int sig) {
  if (g_stop.load()) std::_Exit(128 + sig);
  g_stop_signal.store(sig);
  g_stop.store(true);
}

}  // namespace

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

namespace {

// The step loop: opens (or resumes) the dataset, runs each step's procedure, parks the head
// and closes the dataset.
class Runner : public RunContext {
 public:
  Runner(const std::vector<Protocol>& protocols, robot::RobotInterface& robot, const RunOptions& options)
      : RunContext(robot, options), protocols_(&protocols) {
    for (const Protocol& p : protocols)
      for (const Step& s : p.steps) steps_.push_back({&p, &s});
    num_steps_ = steps_.size();
  }

  RunSummary Run();

 private:
  struct FlatStep {
    const Protocol* protocol;
    const Step* step;
  };

  void RunStep(const FlatStep& fs);

  const std::vector<Protocol>* protocols_ = nullptr;
  std::vector<FlatStep> steps_;
};

void Runner::RunStep(const FlatStep& fs) {
  const Protocol& p = *fs.protocol;
  auto move_through = [&](const std::vector<PlannedPose>& poses, const SettleRule& settle, int frames) {
    for (size_t i = 0; i < poses.size(); ++i) {
      step_work_fraction_ = double(i) / poses.size();
      MoveSettleCapture(poses[i].pwm_us, settle, poses[i].capture ? frames : 0);
    }
  };
  std::visit(Overloaded{
                 [&](const MoveToStep& s) { MoveSettleCapture(s.pose.Resolve(config_), s.settle, s.frames); },
                 [&](const SweepStep& s) { move_through(PlanPoses(s, config_), s.settle, s.frames); },
                 [&](const GridStep& s) { move_through(PlanPoses(s, config_), s.settle, s.frames); },
                 [&](const PlaceTargetStep& s) { RunPlaceTargetStep(*this, p, s); },
                 [&](const CaptureStep& s) {
                   Settle(s.settle);
                   CaptureFrames(s.frames);
                 },
                 [&](const FixateStep& s) { RunFixateStep(*this, p, s); },
                 [&](const StepResponseStep& s) { RunStepResponseStep(*this, p, s); },
                 [&](const LimitsStep& s) { RunLimitsStep(*this, s); },
                 [&](const AlignmentStep& s) { RunAlignmentStep(*this, p, s); },
                 [&](const LatencyStep& s) { RunLatencyStep(*this, s); },
                 [&](const SaccadeStep& s) { RunSaccadeStep(*this, p, s); },
                 [&](const VorStep& s) { RunVorStep(*this, p, s); },
                 [&](const MainSequenceStep& s) { RunMainSequenceStep(*this, p, s); },
                 [&](const CatchUpStep& s) { RunCatchUpStep(*this, p, s); },
                 [&](const TrackStep& s) { RunTrackStep(*this, p, s); },
                 [&](const WaitStep& s) {
                   CheckStop();
                   robot_.SleepNs(int64_t(s.ms) * 1'000'000);
                 },
             },
             fs.step->params);
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
    if (!RecordedWithProtocols(writer_->Manifest(), *protocols_))
      throw std::runtime_error(
          o_.out_dir +
          "/manifest.json: field 'protocols': the dataset was recorded with other protocol files; cannot resume");
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
    writer_->Event(robot_.NowNs(),
                   "resume",
                   "resuming at step " + std::to_string(first_step) + " with " + std::to_string(writer_->NumFrames()) +
                       " frames recorded");
    if (o_.progress)
      *o_.progress << "resuming " << o_.out_dir << " at step " << (first_step + 1) << "/" << steps_.size() << " ("
                   << writer_->NumFrames() << " frames kept)\n";
  } else {
    writer_ = DatasetWriter::Create(o_.out_dir, NewRunManifest(*protocols_, robot_, o_));
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
        if (steps_[i].step->kind() == StepKind::kPlaceTarget) {
          step_index_ = i;
          step_name_ = steps_[i].step->name;
          RunPlaceTargetStep(*this, *steps_[i].protocol, steps_[i].step->As<PlaceTargetStep>());
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
      writer_->Event(t0,
                     "step",
                     "start " + std::to_string(i) + " " + StepKindName(steps_[i].step->kind()) + " '" + step_name_ +
                         "' (" + steps_[i].protocol->name + ")");
      RunStep(steps_[i]);
      writer_->AppendStep(
          {i, step_name_, StepKindName(steps_[i].step->kind()), "done", t0, robot_.NowNs(), step_frames_});
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
    writer_->AppendStep({step_index_,
                         step_name_,
                         StepKindName(steps_[step_index_].step->kind()),
                         "failed",
                         t_start,
                         robot_.NowNs(),
                         step_frames_});
  writer_->Event(robot_.NowNs(), "finish", status + (message.empty() ? "" : ": " + message));
  writer_->Finish(status, message);
  summary_.status = status;
  summary_.message = message;
  summary_.num_frames = writer_->NumFrames();
  summary_.elapsed_s = (robot_.NowNs() - t_start) * 1e-9;
  if (o_.progress) {
    *o_.progress << "run " << status << ": " << summary_.steps_done << "/" << summary_.num_steps << " steps, "
                 << summary_.num_frames << " frames, " << summary_.num_clamped << " commands clamped, "
                 << FixedText(summary_.elapsed_s, 1) << " s robot time" << (message.empty() ? "" : ": " + message)
                 << "\n";
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

RunSummary RunProtocols(const std::vector<Protocol>& protocols,
                        robot::RobotInterface& robot,
                        const RunOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  CheckProtocolsForRobot(protocols, robot.Config());
  Runner r(protocols, robot, options);
  return r.Run();
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
