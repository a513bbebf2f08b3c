#pragma once
// Projection uncertainty of a calibrated camera across its image, as mrcal computes it
// (dkogan/mrcal doc/uncertainty.org): how far the projection of a FIXED point would move if
// the calibration were repeated with new corner noise.
//
// 1. Covariance of the whole calibration state x = [free intrinsics, every board pose] from
//    the per-eye problem: Var(x) = sigma^2 (J^T J)^-1, J = d(corner residuals)/dx at the
//    solution, sigma = the corner noise the fit measured (IntrinsicsFit::corner_sigma_px).
//    Board poses are perturbed on the left: R+ = exp(dr) R, t+ = t + dt.
// 2. A pixel q is unprojected and sent `distance_m` along its ray (or to infinity: a direction),
//    expressed in every board's frame, and reprojected through the perturbed state as the
//    MEAN over the boards of the perturbed board-to-camera transforms (mrcal's "fixed"
//    reference: no single coordinate system is fixed, the boards in aggregate nearly are).
// 3. Var(q) = G Var(x) G^T with G = dq+/dx (central differences); reported is mrcal's default,
//    the worst-direction standard deviation sqrt(largest eigenvalue) [px].
// The intrinsics' own uncertainty includes what the board poses cannot absorb: a principal
// point shift that a rotation of every board explains costs nothing, as it should.
//
// fitting/projection_uncertainty.h (the exports' valid-intrinsics region) is the other, older
// mrcal method: the marginalised intrinsics covariance with a common rotation removed, at
// infinity only. This one keeps the board poses in the state and also answers at a finite
// distance, which the set verdict needs (fronto-parallel boards show as uncertainty at
// distances other than the boards').
//
// Limits (as mrcal says): only corner noise is propagated; a lens the model cannot follow,
// a bent board or blurred corners do not show here. That is why owlcal's verdict also refits
// two halves of the set (evaluation/set_verdict.h).
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "fitting/intrinsics_fit.h"

namespace owlcal::fitting {

struct UncertaintyMapOptions {
  int grid_cols = 16, grid_rows = 12;  // evaluation grid over the image (pixel centres of the cells)
  double distance_m = 0;               // along each pixel's ray, in the target's unit; 0 = infinity
  bool Check(std::string* why) const;
};

struct UncertaintyMap {
  bool ok = false;
  std::string message;  // why not computed (singular: a parameter undetermined)
  int grid_cols = 0, grid_rows = 0;
  std::vector<Eigen::Vector2d> pixels;  // row-major grid
  std::vector<double> sigma_px;         // worst-direction stdev at each grid pixel
  double centre_px = 0;                 // at the image centre
  double median_px = 0, p90_px = 0, max_px = 0;
  // Covariance of the free intrinsics (in camera.params order, fixed ones left out: see
  // free_indices) with the board poses marginalised.
  std::vector<int> free_indices;
  Eigen::MatrixXd intrinsics_covariance;
};

// fit: a successful per-eye fit; views: the views given to FitIntrinsics (only those in
// fit.frame_indices are used, minus fit.rejected corners); fixed: indices of camera.params
// held fixed (internal::FixedIntrinsicIndices of the fit's options).
UncertaintyMap ComputeUncertaintyMap(const IntrinsicsFit& fit,
                                     const std::vector<calib::View>& views,
                                     const std::vector<int>& fixed,
                                     const UncertaintyMapOptions& options = {});

// Median distance of the boards from the camera in `fit` (target unit), 0 if none.
double MedianBoardDistance(const IntrinsicsFit& fit);

}  // namespace owlcal::fitting
