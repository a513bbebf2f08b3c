#include "fitting/distortion_field.h"

#include <cmath>

namespace owlcal::fitting {

std::vector<DistortionArrow> DistortionField(const models::CameraIntrinsics& camera, int nx, int ny) {
  std::vector<DistortionArrow> out;
  if (nx < 1 || ny < 1) return out;
  for (int gy = 0; gy <= ny; ++gy) {
    for (int gx = 0; gx <= nx; ++gx) {
      const double u = (camera.width - 1) * gx / double(nx), v = (camera.height - 1) * gy / double(ny);
      double px[2] = {u, v}, ray[3];
      if (!camera.Unproject(px, ray)) continue;
      DistortionArrow a;
      a.x_pinhole_px = camera.params[0] * ray[0] + camera.params[2];
      a.y_pinhole_px = camera.params[1] * ray[1] + camera.params[3];
      a.dx_px = u - a.x_pinhole_px;
      a.dy_px = v - a.y_pinhole_px;
      a.norm_px = std::hypot(a.dx_px, a.dy_px);
      out.push_back(a);
    }
  }
  return out;
}

}  // namespace owlcal::fitting
