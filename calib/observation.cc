#include "calib/observation.h"

#include <map>
#include <tuple>

namespace owlcal::calib {

std::vector<View> GroupIntoViews(const std::vector<CornerObservation>& obs) {
  std::vector<View> views;
  std::map<std::tuple<int, int, std::string>, size_t> index;
  for (const CornerObservation& o : obs) {
    const auto key = std::make_tuple(o.frame_index, o.eye, o.target_id);
    auto it = index.find(key);
    if (it == index.end()) {
      View v;
      v.frame_index = o.frame_index;
      v.eye = o.eye;
      v.target_id = o.target_id;
      v.pwm_us = o.pwm_us;
      v.approach = o.approach;
      v.stamp_ns = o.stamp_ns;
      it = index.emplace(key, views.size()).first;
      views.push_back(std::move(v));
    }
    View& v = views[it->second];
    v.corner_ids.push_back(o.corner_id);
    v.pixels.push_back(o.pixel);
    v.points_in_target.push_back(o.point_in_target);
  }
  return views;
}

}  // namespace owlcal::calib
