#pragma once
// Where a lens moves image points: for a grid of pixels over the image, the pinhole position
// of the ray the camera maps to that pixel (fx * x + cx, fy * y + cy with (x, y, 1) the
// unprojected ray) and the displacement pixel - pinhole [px]. Pixels (0,0) = centre of the
// top-left pixel (docs/conventions.md, Pixels).
#include <vector>

#include "models/camera_model.h"

namespace owlcal::fitting {

struct DistortionArrow {
  double x_pinhole_px = 0, y_pinhole_px = 0;
  double dx_px = 0, dy_px = 0;  // distorted - pinhole
  double norm_px = 0;           // |(dx, dy)|
};

// (nx + 1) x (ny + 1) pixels from (0, 0) to (width - 1, height - 1), row by row; pixels whose
// ray cannot be found (Unproject fails) are left out.
std::vector<DistortionArrow> DistortionField(const models::CameraIntrinsics& camera, int nx = 16, int ny = 12);

}  // namespace owlcal::fitting
