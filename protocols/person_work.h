#pragma once
// The person's work and the robot's time of a run, per protocol: the target placements it asks a
// person for and the time the robot moves, planned from the protocols before the run (`owlcal
// calibrate --dry-run`) and counted from the recorded datasets after it (results.json
// diagnostics.person_work, the report's summary).
//
// Placements: a place-target step counts when it changes the scene, i.e. its target is not
// already at that pose (within 1 mm and 0.1 deg): a target that stays where it is counts once,
// across the protocols of one run in their order (SceneState carries the scene from one to the
// next). A step with hide_others takes every other target away, except the protocol's
// tag_targets (as the runner does, protocols/placement_step.cc).
//
// Robot time: every step but place-target (whose time is the person's). Planned: the open-loop
// steps (move-to, sweep, grid, capture, alignment, wait) from their poses, settle rules and
// frames at the stream's frame rate, one link round trip per command; the closed-loop steps
// (fixate, limits, step-response, latency, saccade, vor, ...) decide their time from the images
// and are counted, not planned (closed_loop_steps says how many). Counted: steps.csv's
// end_ns - start_ns of every finished step but place-target (the robot's clock).
//
// Usage:
//   protocols::SceneState scene;
//   for (const Protocol& p : loaded) work.push_back(protocols::PlanWork(p, config, &scene));
//   ... after the run, with a fresh scene, in the order they were recorded:
//   work_done.push_back(protocols::CountWork(dataset_dir, &scene_done));
#include <map>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "models/robot_config.h"
#include "protocols/protocol.h"

namespace owlcal::protocols {

// The stream's nominal frame period [s] (30 fps, the Owl user guide).
inline constexpr double kNominalFramePeriodS = 1.0 / 30.0;
// The time one command's round trip over the link costs a step [s] (the virtual Owl's 1 ms).
inline constexpr double kCommandRoundTripS = 0.001;

// Which targets are where: the state a person leaves the scene in.
class SceneState {
 public:
  // Puts `target` at `base_from_target`; with hide_others every other target except `keep` is
  // taken away. True when that changed the scene (the person has something to do).
  bool Place(const std::string& target,
             const Eigen::Isometry3d& base_from_target,
             bool hide_others,
             const std::vector<std::string>& keep);

 private:
  std::map<std::string, Eigen::Isometry3d> placed_;
};

struct ProtocolWork {
  std::string protocol;
  int placements = 0;         // place-target steps that change the scene
  int placement_steps = 0;    // every place-target step (a target left in place is one of these only)
  double robot_time_s = 0;    // planned: the open-loop steps; counted: every step but place-target
  int closed_loop_steps = 0;  // steps whose time the images decide
  double closed_loop_s = 0;   // counted: the part of robot_time_s the closed-loop steps took (planned: 0)
  int steps_not_done = 0;     // counted: steps of the protocol with no "done" line in steps.csv
};

// The planned work of one protocol on `robot`; `scene` is the scene the earlier protocols left.
ProtocolWork PlanWork(const Protocol& protocol,
                      const models::RobotConfig& robot,
                      SceneState* scene,
                      double frame_period_s = kNominalFramePeriodS);

// The work a recorded dataset shows (placements.csv, steps.csv, the protocol texts of its
// manifest); `scene` is the scene the datasets recorded before it left. Throws
// std::runtime_error naming the file when the dataset cannot be read.
ProtocolWork CountWork(const std::string& dataset_dir, SceneState* scene);

// The planned time of one open-loop step [s]; < 0 for a closed-loop step or a place-target step.
double PlannedStepTimeS(const Step& step, const models::RobotConfig& robot, double frame_period_s);

// {"protocol", "placements", "placement_steps", "robot_time_s", "closed_loop_steps", ...}.
nlohmann::json WorkJson(const ProtocolWork& w);
// The same fields summed over protocols, named "total".
ProtocolWork TotalWork(const std::vector<ProtocolWork>& work);
// One line per protocol and the total, for the terminal:
// "  intrinsics     5 placements (5 place-target steps)   13.6 s robot time".
std::vector<std::string> WorkLines(const std::vector<ProtocolWork>& work, bool planned);

}  // namespace owlcal::protocols
