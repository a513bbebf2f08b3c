#pragma once
// Refit of a camera's lens distortion to the 4-coefficient radial-tangential model
// ("radtan": k1 k2 p1 p2, OpenCV's 5-coefficient model with k3 = 0) that Kalibr and other
// tools accept, for exports to tools that cannot represent k3 (or the rational k4..k6).
//
// fx fy cx cy are kept. The rays of a grid of pixels over the whole image (including its edges
// and corners) are unprojected with the original model, and k1 k2 p1 p2 are chosen by linear
// least squares so that the radtan projection of those rays lands on the same pixels (the
// projection is linear in the four coefficients). The error is the pixel distance between
// the original pixel and the radtan projection of its ray, over the same grid.
#include <string>

#include "models/camera_model.h"

namespace owlcal::fitting {

struct RadtanRefit {
  bool ok = false;
  std::string message;                        // why not, when !ok
  models::CameraIntrinsics camera;            // kOpenCv5 with k3 = 0
  double max_error_px = 0, rms_error_px = 0;  // over the image grid
  int num_points = 0;
  bool exact = false;  // the original had no k3..k6: nothing changed
};

// grid: points per image row (columns scaled by the aspect ratio).
RadtanRefit FitRadtan4(const models::CameraIntrinsics& camera, int grid = 41);

}  // namespace owlcal::fitting
