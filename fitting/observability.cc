#include "fitting/observability.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include <ceres/cost_function.h>
#include <ceres/crs_matrix.h>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>

namespace owlcal::fitting {
namespace {

// "a, b, c" with every complete family "p.x" ... (all names of `all` that start with "p.")
// written once as "p.*".
std::string JoinCoupled(const std::vector<int>& idx, const std::vector<std::string>& all) {
  auto prefix = [](const std::string& n) {
    const size_t dot = n.rfind('.');
    return dot == std::string::npos ? std::string() : n.substr(0, dot);
  };
  std::map<std::string, int> family_size, family_seen;
  for (const std::string& n : all) family_size[prefix(n)]++;
  for (int i : idx) family_seen[prefix(all[i])]++;
  std::vector<std::string> out;
  std::set<std::string> done;
  for (int i : idx) {
    const std::string p = prefix(all[i]);
    if (!p.empty() && family_size[p] > 1 && family_seen[p] == family_size[p]) {
      if (done.insert(p).second) out.push_back(p + ".*");
      continue;
    }
    out.push_back(all[i]);
  }
  std::string s;
  for (size_t i = 0; i < out.size(); ++i) s += (i ? ", " : "") + out[i];
  return s;
}

}  // namespace

Observability AnalyseInformation(const Eigen::MatrixXd& information,
                                 const std::vector<std::string>& names,
                                 double rank_tolerance,
                                 const Eigen::VectorXd* diagonal_before_elimination) {
  Observability out;
  const int n = static_cast<int>(information.rows());
  if (n == 0) {
    out.message = "no free parameters";
    return out;
  }
  const Eigen::MatrixXd s = 0.5 * (information + information.transpose());
  out.determined.assign(n, true);
  out.reasons.assign(n, "");
  // Rule 3: unit diagonal.
  Eigen::VectorXd d(n);
  for (int i = 0; i < n; ++i) {
    const double before = diagonal_before_elimination ? (*diagonal_before_elimination)(i) : s(i, i);
    d(i) = 0;
    out.determined[i] = false;
    if (!(before > 0)) {
      out.reasons[i] = "no observation constrains it (zero information)";
    } else if (!(s(i, i) > kEliminatedFraction * before)) {
      out.reasons[i] =
          "the data cannot separate it from the board poses (all its information goes to the eliminated "
          "local blocks)";
    } else {
      d(i) = 1.0 / std::sqrt(s(i, i));
      out.determined[i] = true;
    }
  }
  const Eigen::MatrixXd c = d.asDiagonal() * s * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(c);
  const Eigen::VectorXd& lambda = es.eigenvalues();
  const Eigen::MatrixXd& v = es.eigenvectors();
  const double lmax = std::max(lambda.maxCoeff(), 1e-300);
  out.reciprocal_condition = std::max(0.0, lambda.minCoeff()) / lmax;
  // Rules 4-5: null space and each coordinate's weight in it; the coordinates each null
  // direction involves (|v_j| >= 0.2 max |v|) name the coupling.
  Eigen::VectorXd null_weight = Eigen::VectorXd::Zero(n);
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(n);
  std::vector<std::set<int>> coupled(n);
  for (int k = 0; k < n; ++k) {
    if (lambda(k) > rank_tolerance * lmax) {
      inverse(k) = 1.0 / lambda(k);
      continue;
    }
    ++out.null_dimension;
    null_weight += v.col(k).cwiseAbs2();
    const double vmax = v.col(k).cwiseAbs().maxCoeff();
    std::vector<int> involved;
    for (int j = 0; j < n; ++j)
      if (std::abs(v(j, k)) >= 0.2 * vmax && d(j) > 0) involved.push_back(j);
    for (int i : involved) coupled[i].insert(involved.begin(), involved.end());
  }
  for (int i = 0; i < n; ++i) {
    if (!out.determined[i] || null_weight(i) <= kNullWeightThreshold) continue;
    out.determined[i] = false;
    std::vector<int> others;
    for (int j : coupled[i])
      if (j != i) others.push_back(j);
    if (others.empty()) {
      out.reasons[i] = "no observation constrains it (null space of the information matrix)";
    } else if (names.size() == static_cast<size_t>(n)) {
      out.reasons[i] =
          "the data cannot separate it from " + JoinCoupled(others, names) + " (null space of the information matrix)";
    } else {
      out.reasons[i] = "the data cannot separate it from other parameters (null space of the information matrix)";
    }
  }
  // Rule 6.
  out.covariance = d.asDiagonal() * (v * inverse.asDiagonal() * v.transpose()) * d.asDiagonal();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int i = 0; i < n; ++i) {
    if (out.determined[i]) continue;
    out.covariance.row(i).setConstant(nan);
    out.covariance.col(i).setConstant(nan);
  }
  out.ok = true;
  return out;
}

int FreeTangentSize(ceres::Problem* problem, const std::vector<double*>& blocks) {
  int n = 0;
  for (double* b : blocks)
    if (problem->HasParameterBlock(b) && !problem->IsParameterBlockConstant(b))
      n += problem->ParameterBlockTangentSize(b);
  return n;
}

Observability AnalyseObservability(ceres::Problem* problem,
                                   const std::vector<double*>& global_blocks,
                                   const std::vector<double*>& local_blocks,
                                   const std::vector<std::string>& names,
                                   double rank_tolerance) {
  Observability out;
  // Rule 1: the Jacobian over the free globals, then the free locals.
  std::vector<double*> blocks;
  for (double* b : global_blocks)
    if (problem->HasParameterBlock(b) && !problem->IsParameterBlockConstant(b)) blocks.push_back(b);
  const int ng = FreeTangentSize(problem, global_blocks);
  std::vector<int> local_offsets, local_sizes;
  int col = ng;
  for (double* b : local_blocks) {
    if (!problem->HasParameterBlock(b) || problem->IsParameterBlockConstant(b)) continue;
    blocks.push_back(b);
    local_offsets.push_back(col);
    local_sizes.push_back(problem->ParameterBlockTangentSize(b));
    col += local_sizes.back();
  }
  if (ng == 0) {
    out.message = "no free global parameters";
    return out;
  }
  if (!names.empty() && names.size() != static_cast<size_t>(ng)) {
    out.message =
        "names: " + std::to_string(names.size()) + " given for " + std::to_string(ng) + " tangent coordinates";
    return out;
  }
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.apply_loss_function = false;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(eo, nullptr, nullptr, nullptr, &crs) || crs.num_cols != col) {
    out.message = "Jacobian evaluation failed";
    return out;
  }
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> j(crs.num_rows,
                                                                         crs.num_cols,
                                                                         static_cast<int>(crs.values.size()),
                                                                         crs.rows.data(),
                                                                         crs.cols.data(),
                                                                         crs.values.data());
  const Eigen::SparseMatrix<double> h = Eigen::SparseMatrix<double>(j.transpose()) * j;
  // Rule 2: Schur complement of each local block.
  Eigen::MatrixXd s = Eigen::MatrixXd(h.topLeftCorner(ng, ng));
  for (size_t i = 0; i < local_offsets.size(); ++i) {
    const int o = local_offsets[i], k = local_sizes[i];
    const Eigen::MatrixXd hll = Eigen::MatrixXd(h.block(o, o, k, k));
    const Eigen::MatrixXd hgl = Eigen::MatrixXd(h.block(0, o, ng, k));
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(hll);
    const Eigen::VectorXd ev = es.eigenvalues();
    const double emax = ev.cwiseAbs().maxCoeff();
    Eigen::VectorXd inv = Eigen::VectorXd::Zero(k);
    for (int m = 0; m < k; ++m)
      if (ev(m) > 1e-14 * emax) inv(m) = 1.0 / ev(m);
    s.noalias() -= hgl * (es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose()) * hgl.transpose();
  }
  const Eigen::VectorXd before = Eigen::MatrixXd(h.topLeftCorner(ng, ng)).diagonal();
  return AnalyseInformation(s, names, rank_tolerance, &before);
}

void RaiseToFloor(const Eigen::MatrixXd& floor, Eigen::MatrixXd* c) {
  if (floor.rows() != c->rows() || floor.cols() != c->cols() || floor.rows() == 0) return;
  const Eigen::MatrixXd diff = 0.5 * ((floor - *c) + (floor - *c).transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(diff);
  if (eig.info() != Eigen::Success || eig.eigenvalues().maxCoeff() <= 0) return;
  *c += eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
}

ClusterRobust ClusterRobustCovariance(ceres::Problem* problem,
                                      const std::vector<double*>& global_blocks,
                                      const std::vector<double*>& local_blocks,
                                      const std::function<int(ceres::ResidualBlockId)>& cluster_of,
                                      const Eigen::MatrixXd& model_covariance) {
  ClusterRobust out;
  std::vector<double*> blocks;
  for (double* b : global_blocks)
    if (problem->HasParameterBlock(b) && !problem->IsParameterBlockConstant(b)) blocks.push_back(b);
  const int ng = FreeTangentSize(problem, global_blocks);
  if (ng == 0 || model_covariance.rows() != ng || model_covariance.cols() != ng) {
    out.message = "model covariance is " + std::to_string(model_covariance.rows()) + " x " +
                  std::to_string(model_covariance.cols()) + " for " + std::to_string(ng) + " free global coordinates";
    return out;
  }
  std::vector<int> local_offsets, local_sizes;
  int col = ng;
  for (double* b : local_blocks) {
    if (!problem->HasParameterBlock(b) || problem->IsParameterBlockConstant(b)) continue;
    blocks.push_back(b);
    local_offsets.push_back(col);
    local_sizes.push_back(problem->ParameterBlockTangentSize(b));
    col += local_sizes.back();
  }
  std::vector<ceres::ResidualBlockId> ids;
  problem->GetResidualBlocks(&ids);
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks = blocks;
  eo.residual_blocks = ids;
  eo.apply_loss_function = false;
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  if (!problem->Evaluate(eo, nullptr, &residuals, nullptr, &crs) || crs.num_cols != col) {
    out.message = "Jacobian evaluation failed";
    return out;
  }
  const Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>> j(crs.num_rows,
                                                                         crs.num_cols,
                                                                         static_cast<int>(crs.values.size()),
                                                                         crs.rows.data(),
                                                                         crs.cols.data(),
                                                                         crs.values.data());
  const Eigen::SparseMatrix<double> h = Eigen::SparseMatrix<double>(j.transpose()) * j;
  // Profiling: g_global - K_i g_local,i with K_i = H_gl,i H_ll,i^+.
  std::vector<Eigen::MatrixXd> k_of_local;
  for (size_t i = 0; i < local_offsets.size(); ++i) {
    const int o = local_offsets[i], k = local_sizes[i];
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Eigen::MatrixXd(h.block(o, o, k, k)));
    const Eigen::VectorXd ev = es.eigenvalues();
    const double emax = ev.cwiseAbs().maxCoeff();
    Eigen::VectorXd inv = Eigen::VectorXd::Zero(k);
    for (int m = 0; m < k; ++m)
      if (ev(m) > 1e-14 * emax) inv(m) = 1.0 / ev(m);
    k_of_local.push_back(Eigen::MatrixXd(h.block(0, o, ng, k)) * es.eigenvectors() * inv.asDiagonal() *
                         es.eigenvectors().transpose());
  }
  auto profile = [&](const Eigen::VectorXd& g) {
    Eigen::VectorXd p = g.head(ng);
    for (size_t i = 0; i < local_offsets.size(); ++i)
      p.noalias() -= k_of_local[i] * g.segment(local_offsets[i], local_sizes[i]);
    return p;
  };
  // Scores per cluster; the modelled blocks' information.
  std::map<int, Eigen::VectorXd> score;
  Eigen::MatrixXd modelled = Eigen::MatrixXd::Zero(col, col);
  int row = 0;
  for (ceres::ResidualBlockId id : ids) {
    const int n = problem->GetCostFunctionForResidualBlock(id)->num_residuals();
    const int c = cluster_of(id);
    if (c >= 0) {
      Eigen::VectorXd& g = score.try_emplace(c, Eigen::VectorXd::Zero(col)).first->second;
      for (int r = row; r < row + n; ++r)
        for (Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>>::InnerIterator it(j, r); it; ++it)
          g(it.col()) += it.value() * residuals[r];
    } else {
      for (int r = row; r < row + n; ++r)
        for (Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>>::InnerIterator a(j, r); a; ++a)
          for (Eigen::Map<const Eigen::SparseMatrix<double, Eigen::RowMajor>>::InnerIterator b(j, r); b; ++b)
            modelled(a.col(), b.col()) += a.value() * b.value();
    }
    row += n;
  }
  out.num_clusters = static_cast<int>(score.size());
  if (out.num_clusters < 2) {
    out.message = std::to_string(out.num_clusters) + " cluster(s): a sandwich needs at least 2";
    return out;
  }
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(ng, ng);
  for (const auto& [c, g] : score) {
    const Eigen::VectorXd p = profile(g);
    meat.noalias() += p * p.transpose();
  }
  meat *= double(out.num_clusters) / (out.num_clusters - 1);
  if (!modelled.isZero(0)) {
    // P M_model P^T with P = [I, -K_1, -K_2, ...].
    Eigen::MatrixXd p = Eigen::MatrixXd::Zero(ng, col);
    p.leftCols(ng).setIdentity();
    for (size_t i = 0; i < local_offsets.size(); ++i) p.middleCols(local_offsets[i], local_sizes[i]) = -k_of_local[i];
    meat.noalias() += p * modelled * p.transpose();
  }
  Eigen::MatrixXd bread = model_covariance;
  std::vector<bool> undetermined(ng, false);
  for (int a = 0; a < ng; ++a) undetermined[a] = !std::isfinite(bread(a, a));
  for (int a = 0; a < ng; ++a)
    for (int b = 0; b < ng; ++b)
      if (!std::isfinite(bread(a, b))) bread(a, b) = 0;
  out.covariance = bread * meat * bread;
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose()).eval();
  for (int a = 0; a < ng; ++a)
    if (undetermined[a]) out.covariance.row(a).setConstant(NAN), out.covariance.col(a).setConstant(NAN);
  out.ok = true;
  return out;
}

}  // namespace owlcal::fitting
