#include "protocols/placement_views.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>

#include "calib/observation_io.h"

namespace owlcal::protocols {

std::vector<calib::View> SplitViewsByPlacement(std::vector<calib::View> views,
                                               const std::vector<FrameRecord>& frames,
                                               const std::vector<PlacementRecord>* placements) {
  std::map<int64_t, int> placement_of;
  for (const FrameRecord& f : frames) placement_of[f.frame_index] = f.placement_index;
  // The placement of view v's target in force at its frame (-1: the target was never placed).
  auto target_placement = [&](const calib::View& v, int frame_placement) {
    if (!placements) return frame_placement;
    int latest = -1;
    for (const PlacementRecord& p : *placements)
      if (p.target == v.target_id && p.placement_index <= frame_placement) latest = std::max(latest, p.placement_index);
    return latest;
  };
  std::vector<int> placement_of_view(views.size(), -1);
  std::vector<bool> listed(views.size(), false);
  std::map<std::string, std::set<int>> placements_of_target;
  for (size_t k = 0; k < views.size(); ++k) {
    const auto it = placement_of.find(views[k].frame_index);
    if (it == placement_of.end()) continue;
    listed[k] = true;
    placement_of_view[k] = target_placement(views[k], it->second);
    placements_of_target[views[k].target_id].insert(placement_of_view[k]);
  }
  for (size_t k = 0; k < views.size(); ++k) {
    calib::View& v = views[k];
    if (!listed[k] || placements_of_target[v.target_id].size() < 2) continue;
    v.target_id += "@placement" + std::to_string(placement_of_view[k]);
  }
  return views;
}

std::vector<calib::View> ReadViewsByPlacement(const std::string& dataset_dir) {
  const std::string obs = dataset_dir + "/observations.csv";
  if (!std::filesystem::exists(obs)) return {};
  std::vector<calib::View> views = calib::GroupIntoViews(calib::ReadObservationsCsv(obs));
  if (!std::filesystem::exists(dataset_dir + "/frames.csv")) return views;
  if (!std::filesystem::exists(dataset_dir + "/placements.csv"))
    return SplitViewsByPlacement(std::move(views), ReadFramesCsv(dataset_dir));
  const std::vector<PlacementRecord> placements = ReadPlacementsCsv(dataset_dir);
  return SplitViewsByPlacement(std::move(views), ReadFramesCsv(dataset_dir), &placements);
}

}  // namespace owlcal::protocols
