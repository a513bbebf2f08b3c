#pragma once
// What a fit's data determine, and the covariance of what they do: ONE rule for every fit
// (intrinsics, stereo, head).
//
// Input: a solved Ceres problem whose residuals are whitened (divided by the corner sigma),
// its "global" parameter blocks (intrinsics, extrinsics, servo maps, mounts, eye centres) and
// its "local" blocks (board poses), which are eliminated. Constant blocks take no part.
//
// The rule:
//   1. H = J^T J of the residuals without loss functions, in each block's tangent space (Ceres
//      manifolds: a SubsetManifold's held entries and a quaternion's gauge are not in it).
//   2. The local blocks are eliminated by a Schur complement: S = H_gg - H_gl H_ll^+ H_lg
//      (each local block couples only to globals, as board poses do; H_ll^+ is the
//      pseudo-inverse of that block, eigenvalues below 1e-14 of its largest dropped).
//   3. S is scaled to unit diagonal: C = D S D with D = diag(1 / sqrt(S_ii)) (0 for coordinates
//      rule 5 already rejects), so the rule does not depend on the parameters' units.
//   4. The eigenvectors of C whose eigenvalue is <= rank_tolerance * (largest eigenvalue) span
//      the null space N: directions in which the data do not change the cost.
//   5. A global tangent coordinate i is NOT DETERMINED when
//        - H_ii <= 0: no observation constrains it, or
//        - S_ii <= kEliminatedFraction * H_ii: all its information went to the eliminated local
//          blocks (it moves with the board poses, e.g. a gauge not fixed; rounding leaves such
//          an S_ii tiny but not zero, and step 3 would blow it up to 1), or
//        - its squared weight in N, sum over v in N of v_i^2, exceeds kNullWeightThreshold
//          (0.1): the data cannot separate it from the other coordinates that carry weight
//          in the same null directions, which the reason names.
//   6. Covariance = D C^+ D with C^+ the pseudo-inverse of C on the eigenvectors outside N;
//      rows and columns of coordinates that are not determined are NaN. With whitened
//      residuals it is in the parameters' physical units; scale it by (sigma_hat / sigma)^2
//      when the whitening sigma was a guess.
// A fit may declare more parameters undetermined (a sigma too large to mean anything, a
// parameter held by an option or a gauge); it never reports as determined one this rule
// rejects.
//
// Usage:
//   const Observability o = AnalyseObservability(&problem, {cam.data()}, pose_blocks, names, kDefaultRankTolerance);
//   if (!o.determined[k]) note = o.reasons[k];
#include <functional>
#include <string>
#include <vector>

#include <ceres/problem.h>
#include <Eigen/Core>

namespace owlcal::fitting {

inline constexpr double kNullWeightThreshold = 0.1;
inline constexpr double kEliminatedFraction = 1e-9;
// Rule 4's default: eigenvalues of the unit-diagonal information matrix below 1e-12 of the
// largest are a null space.
inline constexpr double kDefaultRankTolerance = 1e-12;

struct Observability {
  bool ok = false;  // false: message says why (no free global, Jacobian failed)
  std::string message;
  // Over the concatenated tangent coordinates of the non-constant global blocks, in order.
  Eigen::MatrixXd covariance;
  std::vector<bool> determined;
  std::vector<std::string> reasons;  // empty when determined; else why, naming the coupled ones
  int null_dimension = 0;            // eigenvalues at or below the tolerance
  double reciprocal_condition = 0;   // smallest / largest eigenvalue of C (>= 0)
};

// Rules 3-6 on a global information matrix S (symmetric, positive semi-definite). names: one
// per coordinate, used in the reasons (may be empty: then "other parameters").
// diagonal_before_elimination: H_ii of rule 5 (null: S has not been reduced, H_ii = S_ii).
Observability AnalyseInformation(const Eigen::MatrixXd& information,
                                 const std::vector<std::string>& names,
                                 double rank_tolerance,
                                 const Eigen::VectorXd* diagonal_before_elimination = nullptr);

// Rules 1-6 on a problem. names: one per global tangent coordinate (may be empty).
Observability AnalyseObservability(ceres::Problem* problem,
                                   const std::vector<double*>& global_blocks,
                                   const std::vector<double*>& local_blocks,
                                   const std::vector<std::string>& names,
                                   double rank_tolerance);

// The cluster-robust ("sandwich", Huber-White) covariance of the globals of a solved problem:
//   V = B M B,  M = G/(G-1) sum_c g_c g_c^T + sum_(modelled blocks) Jp^T Jp,
// with B the model covariance over the globals (Observability::covariance; NaN rows and columns,
// the undetermined coordinates, are taken as 0 and stay NaN in V), g_c the score of cluster c
// (J_c^T r_c over the residual blocks in it) with the local blocks profiled out
// (g_global - H_gl H_ll^+ g_local, per local block, as rule 2 eliminates them), and G the number
// of clusters. Where residuals in one cluster share an error (a detector bias common to the corners
// of one view or one board placement) that white-noise weighting treats as independent, M
// measures it from the residuals themselves and V is wider than B along the directions it moves;
// where the residuals are white and B's weights right, V -> B. V does not depend on a common scale
// of the whitening sigma. cluster_of: a cluster index >= 0 per residual block, or -1 for a block
// whose model information is taken as it is (a prior: its M term is Jp^T Jp).
struct ClusterRobust {
  bool ok = false;
  std::string message;
  Eigen::MatrixXd covariance;  // over the free global tangent coordinates, like Observability
  int num_clusters = 0;
};
ClusterRobust ClusterRobustCovariance(ceres::Problem* problem,
                                      const std::vector<double*>& global_blocks,
                                      const std::vector<double*>& local_blocks,
                                      const std::function<int(ceres::ResidualBlockId)>& cluster_of,
                                      const Eigen::MatrixXd& model_covariance);

// Raises a symmetric positive semi-definite matrix c to at least `floor` in the Loewner order
// (c + the positive part of floor - c): the result is >= both, and equals c where c already
// covers the floor.
void RaiseToFloor(const Eigen::MatrixXd& floor, Eigen::MatrixXd* c);

// Tangent size of the non-constant blocks among `blocks` in `problem` (0 for constant ones).
int FreeTangentSize(ceres::Problem* problem, const std::vector<double*>& blocks);

}  // namespace owlcal::fitting
