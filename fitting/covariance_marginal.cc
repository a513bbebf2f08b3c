#include "fitting/covariance_marginal.h"

#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SparseCore>
#include <ceres/crs_matrix.h>

namespace owlcal::fitting {

MarginalCovariance ComputeMarginalCovariance(ceres::Problem* problem,
                                             const std::vector<double*>& global_blocks,
                                             const std::vector<double*>& local_blocks,
                                             double rank_tolerance) {
  MarginalCovariance out;
  std::vector<double*> blocks;
  std::vector<int> offsets;
  int ng = 0;
  for (double* b : global_blocks) {
    if (problem->IsParameterBlockConstant(b)) continue;
    blocks.push_back(b);
    offsets.push_back(ng);
    ng += problem->ParameterBlockTangentSize(b);
  }
  std::vector<int> local_offsets, local_sizes;
  int col = ng;
  for (double* b : local_blocks) {
    if (problem->IsParameterBlockConstant(b)) continue;
    blocks.push_back(b);
    local_offsets.push_back(col);
    local_sizes.push_back(problem->ParameterBlockTangentSize(b));
    col += local_sizes.back();
  }
  const int n = col;
  if (ng == 0) {
    out.message = "no free global parameters";
    return out;
  }
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = false;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(eo, nullptr, nullptr, nullptr, &crs)) {
    out.message = "Jacobian evaluation failed";
    return out;
  }
  Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> J(
      crs.num_rows, crs.num_cols, int(crs.values.size()), crs.rows.data(), crs.cols.data(), crs.values.data());
  if (crs.num_cols != n) {
    out.message = "unexpected Jacobian width";
    return out;
  }
  const Eigen::SparseMatrix<double> H = Eigen::SparseMatrix<double>(J.transpose()) * J;
  // Dense pieces: H_gg, and for each local block its H_ll (k x k) and H_gl (ng x k).
  Eigen::MatrixXd S = Eigen::MatrixXd(H.topLeftCorner(ng, ng));
  for (size_t i = 0; i < local_offsets.size(); ++i) {
    const int o = local_offsets[i], k = local_sizes[i];
    const Eigen::MatrixXd Hll = Eigen::MatrixXd(H.block(o, o, k, k));
    const Eigen::MatrixXd Hgl = Eigen::MatrixXd(H.block(0, o, ng, k));
    // Pseudo-inverse of the (usually well conditioned) 6x6 pose block.
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hll);
    const Eigen::VectorXd ev = es.eigenvalues();
    const double emax = ev.cwiseAbs().maxCoeff();
    Eigen::VectorXd inv = Eigen::VectorXd::Zero(k);
    for (int j = 0; j < k; ++j)
      if (ev(j) > 1e-14 * emax) inv(j) = 1.0 / ev(j);
    const Eigen::MatrixXd Hll_inv = es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
    S.noalias() -= Hgl * Hll_inv * Hgl.transpose();
  }
  S = 0.5 * (S + S.transpose());
  out.determined.assign(ng, true);
  out.reasons.assign(ng, "");
  Eigen::VectorXd d(ng);
  for (int i = 0; i < ng; ++i) {
    const double s = S(i, i);
    if (!(s > 0)) {
      d(i) = 0;
      out.determined[i] = false;
      out.reasons[i] = "no information in the data";
    } else {
      d(i) = 1.0 / std::sqrt(s);
    }
  }
  const Eigen::MatrixXd C = d.asDiagonal() * S * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(C);
  const Eigen::VectorXd ev = es.eigenvalues();
  const Eigen::MatrixXd V = es.eigenvectors();
  const double emax = std::max(ev.maxCoeff(), 1e-300);
  out.reciprocal_condition = std::max(0.0, ev.minCoeff()) / emax;
  Eigen::VectorXd null_weight = Eigen::VectorXd::Zero(ng);
  Eigen::VectorXd inv = Eigen::VectorXd::Zero(ng);
  for (int j = 0; j < ng; ++j) {
    if (ev(j) <= rank_tolerance * emax) {
      null_weight += V.col(j).cwiseAbs2();
    } else {
      inv(j) = 1.0 / ev(j);
    }
  }
  for (int i = 0; i < ng; ++i) {
    if (out.determined[i] && null_weight(i) > 0.1) {
      out.determined[i] = false;
      out.reasons[i] = "in the null space of the information matrix (the data cannot separate it from other parameters)";
    }
  }
  const Eigen::MatrixXd Cinv = V * inv.asDiagonal() * V.transpose();
  out.covariance = d.asDiagonal() * Cinv * d.asDiagonal();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < ng; ++i) {
    if (!out.determined[i]) {
      out.covariance.row(i).setConstant(nan);
      out.covariance.col(i).setConstant(nan);
    }
  }
  out.ok = true;
  return out;
}

}  // namespace owlcal::fitting
