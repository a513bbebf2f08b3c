#include "protocols/placement_views.h"

#include <filesystem>
#include <map>
#include <set>

#include "calib/observation_io.h"

namespace owlcal::protocols {

std::vector<calib::View> SplitViewsByPlacement(std::vector<calib::View> views, const std::vector<FrameRecord>& frames) {
  std::map<int64_t, int> placement_of;
  for (const FrameRecord& f : frames) placement_of[f.frame_index] = f.placement_index;
  std::map<std::string, std::set<int>> placements_of_target;
  for (const calib::View& v : views) {
    const auto it = placement_of.find(v.frame_index);
    if (it != placement_of.end()) placements_of_target[v.target_id].insert(it->second);
  }
  for (calib::View& v : views) {
    const auto it = placement_of.find(v.frame_index);
    if (it == placement_of.end() || placements_of_target[v.target_id].size() < 2) continue;
    v.target_id += "@placement" + std::to_string(it->second);
  }
  return views;
}

std::vector<calib::View> ReadViewsByPlacement(const std::string& dataset_dir) {
  const std::string obs = dataset_dir + "/observations.csv";
  if (!std::filesystem::exists(obs)) return {};
  std::vector<calib::View> views = calib::GroupIntoViews(calib::ReadObservationsCsv(obs));
  if (!std::filesystem::exists(dataset_dir + "/frames.csv")) return views;
  return SplitViewsByPlacement(std::move(views), ReadFramesCsv(dataset_dir));
}

}  // namespace owlcal::protocols
