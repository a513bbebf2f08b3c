#include "evaluation/fit_points.h"

#include <algorithm>
#include <cmath>
#include <map>

namespace owlcal::evaluation {

void AddFitPoints(const fitting::StereoFit& fit,
                  const std::vector<calib::View>& views,
                  const std::function<std::string(int frame, int eye)>& name_of,
                  CalibrationRun* d) {
  for (int e = 0; e < 2; ++e) {
    const fitting::IntrinsicsFit& f = fit.per_eye[e];
    std::map<int, size_t> pose_of;
    for (size_t i = 0; i < f.frame_indices.size(); ++i) pose_of[f.frame_indices[i]] = i;
    for (const auto& v : views) {
      if (v.eye != e) continue;
      for (const auto& px : v.pixels) d->coverage.push_back({e, px.x(), px.y()});
      const auto it = pose_of.find(v.frame_index);
      if (!f.ok || it == pose_of.end() || it->second >= f.cam_from_target.size()) continue;
      const models::Rigid3d& cam_from_target = f.cam_from_target[it->second];
      ViewStat st;
      st.eye = e;
      st.frame = v.frame_index;
      st.name = name_of ? name_of(v.frame_index, e) : "frame " + std::to_string(v.frame_index);
      double sum2 = 0;
      for (size_t k = 0; k < v.pixels.size(); ++k) {
        const Eigen::Vector3d p = cam_from_target * v.points_in_target[k];
        double pix[2];
        if (!f.camera.Project(p.data(), pix)) continue;
        const double dx = pix[0] - v.pixels[k].x(), dy = pix[1] - v.pixels[k].y();
        const double r = std::hypot(dx, dy);
        if (r > 5.0) continue;  // rejected outliers are listed by the fit
        d->residuals.push_back({e, v.frame_index, v.pixels[k].x(), v.pixels[k].y(), dx, dy});
        sum2 += r * r;
        ++st.num_corners;
        st.num_over_1px += r > 1.0;
      }
      st.rms_px = st.num_corners ? std::sqrt(sum2 / st.num_corners) : NAN;
      d->views.push_back(st);
      // The outline of the corner grid: the extreme target coordinates (a planar target, z = 0).
      if (v.points_in_target.empty()) continue;
      double x0 = v.points_in_target[0].x(), x1 = x0, y0 = v.points_in_target[0].y(), y1 = y0;
      for (const auto& q : v.points_in_target) {
        x0 = std::min(x0, q.x());
        x1 = std::max(x1, q.x());
        y0 = std::min(y0, q.y());
        y1 = std::max(y1, q.y());
      }
      BoardOutline b;
      b.eye = e;
      b.frame = v.frame_index;
      const Eigen::Vector3d corners[4] = {{x0, y0, 0}, {x1, y0, 0}, {x1, y1, 0}, {x0, y1, 0}};
      for (int k = 0; k < 4; ++k) b.corners_in_cam[k] = cam_from_target * corners[k];
      d->boards.push_back(b);
    }
  }
}

}  // namespace owlcal::evaluation
