#include "protocols/placement_step.h"

#include <algorithm>
#include <iostream>

#include "protocols/step_plan.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

void RunPlaceTargetStep(RunContext& run, const Protocol& p, const PlaceTargetStep& s) {
  PlacementRecord rec;
  rec.step_index = run.step_index();
  rec.target = s.target;
  rec.distance_m = s.distance_m;
  const calib::TargetDefinition* def = nullptr;
  if (auto it = p.targets.find(s.target); it != p.targets.end()) def = &it->second;
  rec.base_from_target = PlacementPose(s, def);
  robot::SceneControl* scene = run.robot().Scene();
  const std::string planned = PlacementPrompt(p, s);
  const bool tag_sheet = std::find(p.tag_targets.begin(), p.tag_targets.end(), s.target) != p.tag_targets.end();
  std::vector<std::string> scene_targets;
  if (scene) scene_targets = scene->TargetNames();
  if (scene && tag_sheet && std::find(scene_targets.begin(), scene_targets.end(), s.target) == scene_targets.end()) {
    // A scene without this tag sheet: the sweep runs on the board alone (tags are an addition).
    rec.source = "scene";
    rec.answer = "absent";
    run.Event("place", "scene has no target '" + s.target + "' (a tag sheet): not placed, not seen");
  } else if (scene) {
    scene->SetTargetPose(s.target, rec.base_from_target);
    if (s.hide_others) {
      for (const std::string& name : scene_targets) {
        // Tag grids stay where they are: fixed in the scene, seen around the boards (tag_targets).
        if (name == s.target || std::find(p.tag_targets.begin(), p.tag_targets.end(), name) != p.tag_targets.end())
          continue;
        scene->SetTargetPose(name, HiddenPose());
      }
    }
    rec.source = "scene";
    run.Event("place", "scene: " + s.target + " at " + FixedText(s.distance_m, 3) + " m");
  } else if (run.options().interactive) {
    std::istream& in = run.options().input ? *run.options().input : std::cin;
    std::ostream& out = run.options().progress ? *run.options().progress : std::cout;
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
        PlaceTargetStep moved = s;
        moved.distance_m = rec.distance_m;
        rec.base_from_target = PlacementPose(moved, def);
      }
    } catch (const std::exception&) {
    }
    run.Event("place", "prompt: '" + planned + "' answered '" + answer + "'");
  } else {
    rec.source = "file";
    run.Event("place", "non-interactive, assumed: " + planned);
  }
  rec.stamp_ns = run.robot().NowNs();
  run.set_placement_index(run.writer().AppendPlacement(rec));
  run.robot().SleepNs(200'000'000);  // frames in flight still show the old scene
}

}  // namespace owlcal::protocols
