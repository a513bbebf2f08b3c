#pragma once
// Where a fitted camera model can be trusted: the projection uncertainty over the image and
// mrcal's valid-intrinsics region.
//
// Projection uncertainty (after mrcal's uncertainty.org, its earlier "fit" method): for a
// point at infinity seen at each pixel of a grid, the pixel's 2x2 covariance is J C J^T with J
// = d pixel / d intrinsics (ray fixed) and C the intrinsics covariance (board poses
// marginalised). A change of the intrinsics that amounts to a rotation of the whole camera is
// absorbed by the extrinsics (the camera frame is only defined through the boards), so the
// part of J that a common rotation explains over the grid is removed first. The value is
// the standard deviation in the worst direction (sqrt of the larger eigenvalue) [px].
//
// Valid-intrinsics region (mrcal-calibrate-cameras' --valid-intrinsics-region-parameters,
// defaults 1 0.5 1.5 3 0): the imager is sampled by a grid of gridn_width x
// round(H / W * gridn_width) cell centres spanning the corner pixels; a cell is valid when the
// projection uncertainty at infinity < 1 x the observed pixel sigma, |mean residual| < 0.5 px,
// residual stdev < 1.5 x the observed pixel sigma and more than 3 residual values fall in it
// (x and y residuals pooled; a cell with 5 values or fewer counts but has mean = stdev = 0, as
// mrcal does). The region is the outline of the largest connected group of valid cells
// (cv::findContours), in pixels, closed (first point repeated last); empty when no cell is
// valid.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "fitting/result.h"
#include "models/camera_model.h"

namespace owlcal::fitting {

struct CornerResidual {
  double x = 0, y = 0;    // measured corner [px]
  double dx = 0, dy = 0;  // reprojected - measured [px]
};

struct UncertaintyGrid {
  int nx = 0, ny = 0;
  std::vector<double> x_px, y_px;  // cell centres, row-major (ny rows of nx)
  std::vector<double> sigma_px;    // worst-direction standard deviation; NaN where unprojectable
};

// cov: covariance of camera.params (same order and size). grid: cells per image row.
UncertaintyGrid ProjectionUncertainty(const models::CameraIntrinsics& camera, const Eigen::MatrixXd& cov, int nx = 30);

// The intrinsics covariance of one eye from a result: the stereo fit's joint covariance
// (stereo.full_covariance) when present, else the diagonal of the parameters' sigmas (no
// correlations: the map is then an upper bound). Undetermined parameters contribute nothing
// (sigma NaN -> 0). `source` says which.
Eigen::MatrixXd IntrinsicsCovariance(const CalibrationResult& result, int eye, std::string* source = nullptr);

struct ValidRegionOptions {
  double threshold_uncertainty = 1.0;  // x observed sigma
  double threshold_mean_px = 0.5;
  double threshold_stdev = 1.5;  // x observed sigma
  int threshold_count = 3;
  int gridn_width = 30;
};

struct ValidIntrinsicsRegion {
  std::vector<Eigen::Vector2d> contour;  // closed outline [px]; empty: no valid cell
  UncertaintyGrid uncertainty;
  std::vector<double> mean_px, stdev_px;
  std::vector<int> count;
  std::vector<bool> valid;
  double observed_sigma_px = 0;
  double valid_fraction = 0;  // of the cells
};

ValidIntrinsicsRegion ComputeValidIntrinsicsRegion(const models::CameraIntrinsics& camera,
                                                   const Eigen::MatrixXd& cov,
                                                   const std::vector<CornerResidual>& residuals,
                                                   double observed_sigma_px,
                                                   const ValidRegionOptions& options = {});

}  // namespace owlcal::fitting
