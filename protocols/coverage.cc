#include "protocols/coverage.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace owlcal::protocols {

bool ComputeViewParams(
    const calib::View& view, const calib::TargetDefinition& target, int width, int height, ViewParams* params) {
  if (view.pixels.size() < 4) return false;
  // Outer corners: the detected corners extreme in target coordinates (works for partial
  // AprilGrid views too): up-left, up-right, down-right, down-left.
  const std::map<int, Eigen::Vector3d> corners = target.Corners();
  int best[4] = {-1, -1, -1, -1};
  double score[4] = {-1e30, -1e30, -1e30, -1e30};
  for (size_t i = 0; i < view.corner_ids.size(); ++i) {
    auto it = corners.find(view.corner_ids[i]);
    if (it == corners.end()) continue;
    const double x = it->second.x(), y = it->second.y();
    const double s[4] = {-x - y, x - y, x + y, -x + y};
    for (int k = 0; k < 4; ++k)
      if (s[k] > score[k]) {
        score[k] = s[k];
        best[k] = int(i);
      }
  }
  for (int k = 0; k < 4; ++k)
    if (best[k] < 0) return false;
  const Eigen::Vector2d ul = view.pixels[best[0]], ur = view.pixels[best[1]], dr = view.pixels[best[2]],
                        dl = view.pixels[best[3]];
  // Shoelace area of the quadrilateral.
  const Eigen::Vector2d q[4] = {ul, ur, dr, dl};
  double area = 0;
  for (int k = 0; k < 4; ++k) area += q[k].x() * q[(k + 1) % 4].y() - q[(k + 1) % 4].x() * q[k].y();
  area = std::abs(area) / 2;
  const double border = std::sqrt(area);
  double mx = 0, my = 0;
  for (const Eigen::Vector2d& p : view.pixels) {
    mx += p.x();
    my += p.y();
  }
  mx /= view.pixels.size();
  my /= view.pixels.size();
  params->x = std::clamp((mx - border / 2) / (width - border), 0.0, 1.0);
  params->y = std::clamp((my - border / 2) / (height - border), 0.0, 1.0);
  params->size = std::sqrt(area / (double(width) * height));
  const Eigen::Vector2d a = ul - ur, b = dr - ur;
  const double angle = std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0));
  params->skew = std::min(1.0, 2 * std::abs(M_PI / 2 - angle));
  return true;
}

Coverage ComputeCoverage(const std::vector<ViewParams>& views) {
  Coverage c;
  c.num_views = int(views.size());
  if (views.empty()) return c;
  static const double kRanges[4] = {0.7, 0.7, 0.4, 0.5};
  for (int k = 0; k < 4; ++k) {
    c.min[k] = 1e9;
    c.max[k] = -1e9;
  }
  for (const ViewParams& v : views) {
    const double p[4] = {v.x, v.y, v.size, v.skew};
    for (int k = 0; k < 4; ++k) {
      c.min[k] = std::min(c.min[k], p[k]);
      c.max[k] = std::max(c.max[k], p[k]);
    }
  }
  for (int k = 0; k < 4; ++k) c.progress[k] = std::min(1.0, (c.max[k] - c.min[k]) / kRanges[k]);
  return c;
}

std::string Coverage::Bars() const {
  static const char* kNames[4] = {"X   ", "Y   ", "Size", "Skew"};
  std::ostringstream o;
  for (int k = 0; k < 4; ++k) {
    const int n = int(std::lround(progress[k] * 20));
    o << kNames[k] << " [" << std::string(n, '#') << std::string(20 - n, '-') << "] "
      << int(std::lround(progress[k] * 100)) << "%  (" << min[k] << " .. " << max[k] << ")\n";
  }
  return o.str();
}

}  // namespace owlcal::protocols
