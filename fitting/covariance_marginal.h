#pragma once
// Marginal covariance of a Ceres problem's "global" parameter blocks (camera intrinsics,
// stereo extrinsics) with the per-view "local" blocks (board poses) eliminated by a Schur
// complement, plus an observability analysis: which tangent directions the data cannot
// determine.
//
// The information matrix is H = J^T J of the problem's (whitened) residuals without loss
// functions, in each block's tangent space (Ceres manifolds). Local blocks must only couple
// to globals, not to each other (true for board poses). With residuals whitened by the corner
// sigma the covariance is in physical units; multiply by (sigma_hat / sigma_used)^2 otherwise.
//
// Observability: H_gg - H_gl H_ll^-1 H_lg is scaled to unit diagonal; eigenvalues below
// rank_tolerance * largest span the null space. A global tangent coordinate whose squared
// weight in the null space exceeds 0.1 (or whose information is zero) is "undetermined";
// its covariance row/column is NaN. The rest is the pseudo-inverse restricted to the
// determined subspace.
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ceres/problem.h>

namespace owlcal::fitting {

struct MarginalCovariance {
  bool ok = false;
  std::string message;
  Eigen::MatrixXd covariance;          // over the concatenated tangent spaces of the globals
  std::vector<bool> determined;        // per tangent coordinate
  std::vector<std::string> reasons;    // per tangent coordinate, empty when determined
  double reciprocal_condition = 0;     // smallest / largest scaled eigenvalue
};

// global_blocks: in the order of the result's rows (tangent sizes concatenated).
// local_blocks: eliminated (each must be in the problem; constant blocks are skipped).
// Constant global blocks contribute no rows (their tangent size is taken as 0).
MarginalCovariance ComputeMarginalCovariance(ceres::Problem* problem,
                                             const std::vector<double*>& global_blocks,
                                             const std::vector<double*>& local_blocks,
                                             double rank_tolerance = 1e-12);

}  // namespace owlcal::fitting
