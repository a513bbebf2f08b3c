#pragma once
// How differently two calibrations of the same camera project (mrcal's projection diff,
// mrcal-show-projection-diff): each grid pixel q is unprojected through `a` to a direction
// (a point at infinity), rotated by the rotation that best maps a's camera frame onto b's, and
// projected through `b`; the difference |q' - q| [px] is what a user would see if they
// swapped one calibration for the other. The rotation is fitted (Gauss-Newton on a rotation
// vector) over the grid pixels within `fit_radius_fraction` of the half-diagonal from the image
// centre: two calibrations may disagree about the camera's orientation relative to the boards
// without disagreeing about the lens, so that part is taken out first. Fails (ok = false) when
// more than a quarter of the grid cannot be unprojected through `a`.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/camera_model.h"

namespace owlcal::evaluation {

struct ProjectionDiff {
  bool ok = false;
  std::string message;
  int grid_cols = 0, grid_rows = 0;
  std::vector<Eigen::Vector2d> pixels;  // row-major grid
  std::vector<double> diff_px;          // |q' - q| at each grid pixel (infinite where `a` cannot unproject)
  double centre_px = 0, median_px = 0, p90_px = 0, max_px = 0;
  double rotation_deg = 0;  // size of the fitted rotation
};

// a, b: the same camera calibrated twice (same image size).
ProjectionDiff CompareProjection(const models::CameraIntrinsics& a,
                                 const models::CameraIntrinsics& b,
                                 int grid_cols = 16,
                                 int grid_rows = 12,
                                 double fit_radius_fraction = 0.6);

}  // namespace owlcal::evaluation
