#include "fitting/board_warp.h"

#include <algorithm>

namespace owlcal::fitting {

std::string BoardOfTarget(const std::string& target_id) { return target_id.substr(0, target_id.find('@')); }

WarpSpan WarpSpanOfViews(const std::vector<calib::View>& views, const std::string& board) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const calib::View& v : views) {
    if (!board.empty() && BoardOfTarget(v.target_id) != board) continue;
    for (const Eigen::Vector3d& p : v.points_in_target) {
      x0 = std::min(x0, p.x());
      x1 = std::max(x1, p.x());
      y0 = std::min(y0, p.y());
      y1 = std::max(y1, p.y());
    }
  }
  WarpSpan s;
  if (x0 > x1) return s;  // no corners: the identity span (no warp is determined anyway)
  s.centre_x = (x0 + x1) / 2;
  s.centre_y = (y0 + y1) / 2;
  s.half_x = std::max(1e-9, (x1 - x0) / 2);
  s.half_y = std::max(1e-9, (y1 - y0) / 2);
  return s;
}

}  // namespace owlcal::fitting
