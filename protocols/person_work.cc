#include "protocols/person_work.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "protocols/dataset.h"
#include "protocols/step_plan.h"

namespace owlcal::protocols {
namespace {

// Two poses one placement apart: within 1 mm and 0.1 deg.
bool SamePose(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  const double angle = Eigen::AngleAxisd(a.rotation().transpose() * b.rotation()).angle();
  return (a.translation() - b.translation()).norm() < 1e-3 && angle < 0.1 * M_PI / 180.0;
}

double SettleTimeS(const SettleRule& rule, double frame_period_s) {
  if (rule.mode == SettleRule::Mode::kTime) return rule.time_ms / 1000.0;
  // Image mode: at least min_ms, then still_frames still frame pairs (a robot at rest).
  return rule.min_ms / 1000.0 + rule.still_frames * frame_period_s;
}

// After a settle the newest frame is already there; each further frame waits one period.
double CaptureTimeS(int frames, double frame_period_s) { return std::max(0, frames - 1) * frame_period_s; }

double PosesTimeS(const std::vector<PlannedPose>& poses, const SettleRule& settle, int frames, double period) {
  double t = 0;
  for (const PlannedPose& p : poses)
    t += kCommandRoundTripS + SettleTimeS(settle, period) + (p.capture ? CaptureTimeS(frames, period) : 0);
  return t;
}

// The steps PlannedStepTimeS cannot plan: their time is decided by the images.
bool IsClosedLoop(const Step& s) {
  switch (s.kind()) {
    case StepKind::kMoveTo:
    case StepKind::kSweep:
    case StepKind::kGrid:
    case StepKind::kCapture:
    case StepKind::kAlignment:
    case StepKind::kWait:
    case StepKind::kPlaceTarget:
      return false;
    default:
      return true;
  }
}

std::string Seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, "%.1f s", s);
  return b;
}

}  // namespace

bool SceneState::Place(const std::string& target,
                       const Eigen::Isometry3d& base_from_target,
                       bool hide_others,
                       const std::vector<std::string>& keep) {
  bool changed = false;
  if (hide_others) {
    for (auto it = placed_.begin(); it != placed_.end();) {
      if (it->first != target && std::find(keep.begin(), keep.end(), it->first) == keep.end()) {
        it = placed_.erase(it);
        changed = true;
      } else {
        ++it;
      }
    }
  }
  const auto it = placed_.find(target);
  if (it == placed_.end() || !SamePose(it->second, base_from_target)) changed = true;
  placed_[target] = base_from_target;
  return changed;
}

double PlannedStepTimeS(const Step& step, const models::RobotConfig& robot, double period) {
  return std::visit(
      Overloaded{
          [&](const MoveToStep& s) {
            return kCommandRoundTripS + SettleTimeS(s.settle, period) + CaptureTimeS(s.frames, period);
          },
          [&](const SweepStep& s) { return PosesTimeS(PlanPoses(s, robot), s.settle, s.frames, period); },
          [&](const GridStep& s) { return PosesTimeS(PlanPoses(s, robot), s.settle, s.frames, period); },
          [&](const CaptureStep& s) { return SettleTimeS(s.settle, period) + CaptureTimeS(s.frames, period); },
          [&](const AlignmentStep& s) {
            return kCommandRoundTripS + SettleTimeS(s.settle, period) + CaptureTimeS(s.frames, period);
          },
          [&](const WaitStep& s) { return s.ms / 1000.0; },
          [&](const auto&) { return -1.0; },
      },
      step.params);
}

ProtocolWork PlanWork(const Protocol& p, const models::RobotConfig& robot, SceneState* scene, double period) {
  ProtocolWork w;
  w.protocol = p.name;
  for (const Step& s : p.steps) {
    if (s.kind() == StepKind::kPlaceTarget) {
      const PlaceTargetStep& pt = s.As<PlaceTargetStep>();
      const auto def = p.targets.find(pt.target);
      ++w.placement_steps;
      w.placements += scene->Place(
          pt.target, PlacementPose(pt, def == p.targets.end() ? nullptr : &def->second), pt.hide_others, p.tag_targets);
      continue;
    }
    if (IsClosedLoop(s))
      ++w.closed_loop_steps;
    else
      w.robot_time_s += PlannedStepTimeS(s, robot, period);
  }
  return w;
}

ProtocolWork CountWork(const std::string& dir, SceneState* scene) {
  const nlohmann::json m = ReadManifest(dir);
  // The steps as the runner numbered them: the manifest's protocols, concatenated.
  std::vector<Protocol> protocols;
  for (const auto& entry : m.value("protocols", nlohmann::json::array()))
    if (entry.contains("text") && entry["text"].is_string())
      protocols.push_back(ParseProtocolYaml(entry["text"].get<std::string>(), dir + "/manifest.json"));
  if (protocols.empty()) throw std::runtime_error(dir + "/manifest.json: field 'protocols' holds no protocol text");
  struct Flat {
    const Protocol* protocol;
    const Step* step;
  };
  std::vector<Flat> flat;
  ProtocolWork w;
  for (const Protocol& p : protocols) {
    w.protocol += (w.protocol.empty() ? "" : "+") + p.name;
    for (const Step& s : p.steps) flat.push_back({&p, &s});
  }
  // The robot clock of each finished step.
  int done = 0;
  for (const StepRecord& r : ReadStepsCsv(dir)) {
    done += r.status == "done";
    if (r.kind == "place-target") continue;
    const double t = (r.end_ns - r.start_ns) * 1e-9;
    w.robot_time_s += t;
    if (r.step_index >= 0 && r.step_index < int(flat.size()) && IsClosedLoop(*flat[r.step_index].step))
      w.closed_loop_s += t;
  }
  for (const Flat& f : flat) w.closed_loop_steps += IsClosedLoop(*f.step);
  w.steps_not_done = std::max(0, int(flat.size()) - done);
  // Every placement the run made, judged against the scene as the earlier ones left it.
  for (const PlacementRecord& r : ReadPlacementsCsv(dir)) {
    if (r.step_index < 0 || r.step_index >= int(flat.size()) ||
        flat[r.step_index].step->kind() != StepKind::kPlaceTarget)
      throw std::runtime_error(dir + "/placements.csv: placement " + std::to_string(r.placement_index) +
                               ": column step_index " + std::to_string(r.step_index) +
                               " is not a place-target step of the manifest's protocols");
    const PlaceTargetStep& pt = flat[r.step_index].step->As<PlaceTargetStep>();
    ++w.placement_steps;
    w.placements +=
        scene->Place(r.target, r.base_from_target, pt.hide_others, flat[r.step_index].protocol->tag_targets);
  }
  return w;
}

nlohmann::json WorkJson(const ProtocolWork& w) {
  return {{"protocol", w.protocol},
          {"placements", w.placements},
          {"placement_steps", w.placement_steps},
          {"robot_time_s", w.robot_time_s},
          {"closed_loop_steps", w.closed_loop_steps},
          {"closed_loop_s", w.closed_loop_s},
          {"steps_not_done", w.steps_not_done}};
}

ProtocolWork TotalWork(const std::vector<ProtocolWork>& work) {
  ProtocolWork t;
  t.protocol = "total";
  for (const ProtocolWork& w : work) {
    t.placements += w.placements;
    t.placement_steps += w.placement_steps;
    t.robot_time_s += w.robot_time_s;
    t.closed_loop_steps += w.closed_loop_steps;
    t.closed_loop_s += w.closed_loop_s;
    t.steps_not_done += w.steps_not_done;
  }
  return t;
}

std::vector<std::string> WorkLines(const std::vector<ProtocolWork>& work, bool planned) {
  std::vector<std::string> out;
  std::vector<ProtocolWork> rows = work;
  rows.push_back(TotalWork(work));
  for (const ProtocolWork& w : rows) {
    char b[256];
    std::snprintf(b,
                  sizeof b,
                  "  %-14s %3d placements (%2d place-target steps)  %8s robot time",
                  w.protocol.c_str(),
                  w.placements,
                  w.placement_steps,
                  Seconds(w.robot_time_s).c_str());
    std::string line = b;
    if (planned && w.closed_loop_steps > 0)
      line += " + " + std::to_string(w.closed_loop_steps) + " closed-loop steps (their time is decided at run time)";
    if (!planned && w.closed_loop_steps > 0)
      line +=
          " (" + Seconds(w.closed_loop_s) + " of it in " + std::to_string(w.closed_loop_steps) + " closed-loop steps)";
    if (!planned && w.steps_not_done > 0) line += "; " + std::to_string(w.steps_not_done) + " steps not done";
    out.push_back(line);
  }
  return out;
}

}  // namespace owlcal::protocols
