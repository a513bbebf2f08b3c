// The covariance of FitHead (declared in fitting/head_problem.h): the observability analysis of
// the free head blocks, its cluster-robust form, and the floors and widenings the options ask for
// (hysteresis, intrinsics carried to the servo maps, pan zero, focal scale, principal points).
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <ceres/ceres.h>
#include <Eigen/Dense>

#include "fitting/head_gauge.h"
#include "fitting/head_problem.h"
#include "fitting/observability.h"

namespace owlcal::fitting::internal {
namespace {

// HeadFitOptions::pan_zero_sigma_factor: C += (factor^2 - 1) var(g) w w^T / (a^T w)^2, with g = a^T x
// the two pan maps' mean angle at the robot file's centres and w the tangent direction that shifts
// both pan maps by one angle (fitting/head_gauge.h ShiftServoMapAngle), so g's sigma grows by the
// factor and every other parameter keeps its own. Coordinates without a finite variance (held or
// undetermined) take no part. With floor_rad > 0 the factor is at least floor_rad / sigma(g)
// (pan_zero_sigma_floor_deg). Returns g's sigma after [rad] (NaN when it has none).
double WidenPanZero(
    const HeadState& s, const models::RobotConfig& robot, double factor, double floor_rad, HeadCovariance* cov) {
  Eigen::MatrixXd& c = cov->analysis.covariance;
  std::vector<int> idx;  // tangent coordinates of the pan maps
  std::vector<double> w, a;
  constexpr double kDelta = 1e-4;  // rad
  for (int e = 0; e < 2; ++e) {
    const int servo = models::kPanServo[e];
    const Block& b = s.servo[servo];
    std::array<double, 5> p;
    std::copy(b.values.begin(), b.values.end(), p.begin());
    const int dir = robot.servos[servo].direction;
    const std::array<double, 5> up = ShiftServoMapAngle(p, dir, kDelta), down = ShiftServoMapAngle(p, dir, -kDelta);
    // d angle / d params at the centre command (models/servo_map.h: the angle is linear in the
    // scale and the nonlinear terms; hysteresis does not enter at approach 0).
    const double u0 = robot.servos[servo].centre_us, du = u0 - p[0], x = du / models::ServoMap::kNormUs;
    const double rad = dir * M_PI / 180.0;
    const std::array<double, 5> grad = {
        -models::ServoMap::Slope(p.data(), dir, u0, 0), rad * du, rad * x * x, rad * x * x * x, 0.0};
    for (int k = 0; k < 5; ++k) {
      const auto it = cov->tangent_of.find({&b, k});
      if (it == cov->tangent_of.end() || !std::isfinite(c(it->second, it->second))) continue;
      idx.push_back(it->second);
      w.push_back((up[k] - down[k]) / (2 * kDelta));
      a.push_back(0.5 * grad[k]);
    }
  }
  double var = 0, aw = 0;
  for (size_t i = 0; i < idx.size(); ++i) {
    aw += a[i] * w[i];
    for (size_t j = 0; j < idx.size(); ++j) var += a[i] * c(idx[i], idx[j]) * a[j];
  }
  if (!(var > 0) || !(std::abs(aw) > 0)) return NAN;
  // The floor: g's sigma at least floor_rad (HeadFitOptions::pan_zero_sigma_floor_deg).
  if (floor_rad > 0) factor = std::max(factor, floor_rad / std::sqrt(var));
  const double add = (factor * factor - 1) * var / (aw * aw);
  for (size_t i = 0; i < idx.size(); ++i)
    for (size_t j = 0; j < idx.size(); ++j) c(idx[i], idx[j]) += add * w[i] * w[j];
  return factor * std::sqrt(var);
}

// The covariance of y = A x (A: m x n over the tangent coordinates) raised to at least F: the
// shortfall D = F - A C A^T, its negative eigenvalues dropped, added along what the covariance
// moves with y: C += B D B^T, B = C A^T (A C A^T)^-1 (so A C A^T becomes A C A^T + D and y's
// conditional covariance keeps the rest). Coordinates without a finite variance take no part.
// Returns A C A^T before (empty when it is not positive definite).
Eigen::MatrixXd RaiseLinearCombination(const Eigen::MatrixXd& a, const Eigen::MatrixXd& floor, Eigen::MatrixXd* cov) {
  Eigen::MatrixXd& c = *cov;
  const int n = int(c.rows());
  Eigen::MatrixXd cf = c;  // finite part
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (!std::isfinite(cf(i, j)) || !std::isfinite(c(i, i)) || !std::isfinite(c(j, j))) cf(i, j) = 0;
  const Eigen::MatrixXd cat = cf * a.transpose();  // n x m
  const Eigen::MatrixXd v = a * cat;
  Eigen::LLT<Eigen::MatrixXd> llt(v);
  if (llt.info() != Eigen::Success) return {};
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(0.5 * ((floor - v) + (floor - v).transpose()));
  if (eig.info() != Eigen::Success || eig.eigenvalues().maxCoeff() <= 0) return v;
  const Eigen::MatrixXd d =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
  const Eigen::MatrixXd b = llt.solve(cat.transpose()).transpose();  // C A^T V^-1
  const Eigen::MatrixXd add = b * d * b.transpose();
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      if (std::isfinite(c(i, j))) c(i, j) += add(i, j);
  return v;
}

// HeadFitOptions::focal_scale_sigma_floor: g = mean of log fx, log fy over both eyes, raised to
// the floor (RaiseLinearCombination). Returns g's sigma before (NaN when the fit has no focal
// length with a finite variance).
double FloorFocalScale(const HeadState& s, double floor, HeadCovariance* cov) {
  const Eigen::MatrixXd& c = cov->analysis.covariance;
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(1, c.rows());
  int num = 0;
  for (int e = 0; e < 2; ++e) {
    const Block& b = s.camera[e];
    for (int k = 0; k < 2 && k < b.size(); ++k) {  // fx, fy
      const auto it = cov->tangent_of.find({&b, k});
      const double f = b.values[k];
      if (it == cov->tangent_of.end() || !std::isfinite(c(it->second, it->second)) || !(f > 0)) continue;
      a(0, it->second) = 1.0 / f;  // d log f / d value (the block holds f itself, scaled)
      ++num;
    }
  }
  if (num == 0) return NAN;
  a /= num;
  const Eigen::MatrixXd v =
      RaiseLinearCombination(a, Eigen::MatrixXd::Constant(1, 1, floor * floor), &cov->analysis.covariance);
  return v.size() == 1 ? std::sqrt(v(0, 0)) : NAN;
}

// HeadFitOptions::principal_point_covariance_floor: each eye's (cx, cy) block raised to its floor
// (the shortfall, its negative eigenvalues dropped, added to that block alone).
void FloorPrincipalPoints(const HeadState& s, const HeadFitOptions& options, HeadCovariance* cov) {
  Eigen::MatrixXd& c = cov->analysis.covariance;
  for (int e = 0; e < 2; ++e) {
    const auto& floor = options.principal_point_covariance_floor[e];
    const Block& b = s.camera[e];
    if (!floor || floor->rows() != 2 || floor->cols() != 2 || b.size() < 4) continue;
    int t[2];
    bool all = true;
    for (int k = 0; k < 2; ++k) {
      const auto it = cov->tangent_of.find({&b, 2 + k});
      all = all && it != cov->tangent_of.end() && std::isfinite(c(it->second, it->second));
      if (all) t[k] = it->second;
    }
    if (!all) continue;
    Eigen::MatrixXd block(2, 2);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) block(i, j) = c(t[i], t[j]);
    RaiseToFloor(*floor, &block);
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) c(t[i], t[j]) = block(i, j);
  }
}

// HeadFitOptions::hysteresis_sigma_floor_us: each servo's hysteresis sigma at least the floor.
void FloorHysteresis(const HeadState& s, const HeadFitOptions& options, HeadCovariance* c) {
  HeadCovariance& cov = *c;
  // Raising a diagonal entry keeps the covariance positive semi-definite.
  for (const Block& b : s.servo) {
    auto it = cov.tangent_of.find({&b, 4});  // hysteresis_us
    if (it == cov.tangent_of.end() || !(b.scale[4] > 0)) continue;
    const double floor = options.hysteresis_sigma_floor_us / b.scale[4];
    double& v = cov.analysis.covariance(it->second, it->second);
    v = std::max(v, floor * floor);
  }
}

// HeadFitOptions::intrinsics_covariance_floor: each eye's intrinsics block raised to its floor,
// carried as intrinsics_floor_carry says.
void FloorIntrinsics(const HeadState& s, const HeadFitOptions& options, HeadCovariance* c) {
  HeadCovariance& cov = *c;
  for (int e = 0; e < 2; ++e) {
    if (!options.intrinsics_covariance_floor[e]) continue;
    const Eigen::MatrixXd& floor = *options.intrinsics_covariance_floor[e];
    const Block& b = s.camera[e];
    if (floor.rows() != b.size() || floor.cols() != b.size()) continue;
    std::vector<int> tangent, ambient;
    for (int a = 0; a < b.size(); ++a) {
      auto it = cov.tangent_of.find({&b, a});
      if (it == cov.tangent_of.end()) continue;
      tangent.push_back(it->second);
      ambient.push_back(a);
    }
    const int k = int(tangent.size());
    if (k == 0) continue;
    Eigen::MatrixXd& c = cov.analysis.covariance;
    Eigen::MatrixXd ckk(k, k), f(k, k);
    for (int i = 0; i < k; ++i) {
      for (int j = 0; j < k; ++j) {
        ckk(i, j) = c(tangent[i], tangent[j]);
        f(i, j) = floor(ambient[i], ambient[j]);
      }
    }
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(f - ckk);
    if (eig.info() != Eigen::Success || eig.eigenvalues().maxCoeff() <= 0) continue;
    const Eigen::MatrixXd d =
        eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).asDiagonal() * eig.eigenvectors().transpose();
    // The shortfall on the intrinsics' block, and carried (intrinsics_floor_carry) to the servo
    // centres or every servo map coordinate as the fit's own covariance says they move with the
    // intrinsics: C += B D B^T, B = C_(rows,k) C_kk^-1 on the intrinsics' rows (there the
    // identity) and the carried rows, 0 elsewhere. A principal-point error turns the camera
    // frame, and each eye's pan and tilt zeros turn with it (the gauge ties them: on 30 robots
    // of the prior the tilt centres, left out, were 1.7-2.3 sigma RMS); a focal-length error
    // scales every angle the maps give (the five servo scales' relative errors are minus the
    // focal length's). Carried to every correlated parameter it made the head geometry
    // over-wide (90.6 % within 1 sigma on 8 robots of the prior, RMS(z) 0.64).
    const int n = int(c.rows());
    std::vector<bool> carry(n, false);
    for (int t : tangent) carry[t] = true;
    if (options.intrinsics_floor_carry != FloorCarry::kNone) {
      for (const Block& servo : s.servo) {
        for (int a = 0; a < servo.size(); ++a) {
          if (a != 0 && options.intrinsics_floor_carry == FloorCarry::kCentres) continue;  // 0: centre_us
          auto it = cov.tangent_of.find({&servo, a});
          if (it != cov.tangent_of.end()) carry[it->second] = true;
        }
      }
    }
    Eigen::MatrixXd cak = Eigen::MatrixXd::Zero(n, k);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < k; ++j)
        if (carry[i] && std::isfinite(c(i, tangent[j]))) cak(i, j) = c(i, tangent[j]);
    const Eigen::MatrixXd a = cak * ckk.completeOrthogonalDecomposition().pseudoInverse();
    const Eigen::MatrixXd add = a * d * a.transpose();
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        if (std::isfinite(c(i, j))) c(i, j) += add(i, j);
  }
}

}  // namespace

// The observability analysis over the free head blocks with the boards eliminated.
HeadCovariance AnalyseHead(ceres::Problem* problem,
                           HeadState* s,
                           const std::vector<calib::View>& views,
                           const HeadFitOptions& options) {
  HeadCovariance c;
  std::vector<double*> globals, locals;
  std::vector<std::string> names;
  int offset = 0;
  for (Block* b : s->HeadBlocks()) {
    if (!b->in_problem || b->AllFixed()) continue;
    globals.push_back(b->data());
    for (int k = 0; k < b->TangentSize(); ++k) {
      const int a = b->AmbientOfTangent(k);
      c.tangent_of[{b, a}] = offset + k;
      names.push_back(b->names[a]);
    }
    offset += b->TangentSize();
  }
  for (Block* b : s->BoardBlocks())
    if (b->in_problem) locals.push_back(b->data());
  c.names = names;
  if (offset == 0) return c;
  c.analysis = AnalyseObservability(problem, globals, locals, names, options.rank_tolerance);
  if (options.covariance_clusters.kind == CovarianceClusters::Kind::kModel || !c.analysis.ok) return c;
  // The covariance the residuals show, clustered (HeadFitOptions::covariance_clusters), never
  // below white noise at the measured sigma.
  auto sandwich = [&](const CovarianceClusters& spec) {
    // kView: one residual block per view; kPlacement: the views of one board placement by one
    // eye; kCell: the views of one board placement whose five commands fall in the same cell
    // (both eyes' views of a frame together).
    const double cell_us = spec.kind == CovarianceClusters::Kind::kCell ? spec.cell_us : 0.0;
    std::map<std::pair<const double*, const double*>, int> placement;
    std::map<ceres::ResidualBlockId, int> view_index;
    std::map<std::pair<const double*, std::array<long, models::kNumServos>>, int> cell;
    auto cluster_of = [&](ceres::ResidualBlockId id) {
      std::vector<double*> blocks;
      problem->GetParameterBlocksForResidualBlock(id, &blocks);
      if (blocks.size() != 8) return -1;  // a prior
      if (spec.kind == CovarianceClusters::Kind::kView)
        return view_index.try_emplace(id, int(view_index.size())).first->second;
      if (cell_us > 0) {
        const calib::View& v = views.at(s->input_view_of_residual.at(id));
        std::array<long, models::kNumServos> key{};
        for (int k = 0; k < models::kNumServos; ++k) key[k] = std::lround(std::floor(v.pwm_us[k] / cell_us));
        return cell.try_emplace({blocks[5], key}, int(cell.size())).first->second;
      }
      return placement.try_emplace({blocks[5], blocks[6]}, int(placement.size())).first->second;
    };
    return ClusterRobustCovariance(problem, globals, locals, cluster_of, c.analysis.covariance);
  };
  const ClusterRobust robust = sandwich(options.covariance_clusters);
  c.num_clusters = robust.num_clusters;
  c.clusters_message = robust.message;
  if (!robust.ok) return c;
  Eigen::MatrixXd white =
      c.analysis.covariance /
      (options.estimate_corner_sigma ? options.measured_sigma_factor * options.measured_sigma_factor : 1.0);
  Eigen::MatrixXd v = robust.covariance;
  std::vector<bool> undetermined(offset);
  for (int a = 0; a < offset; ++a) undetermined[a] = !std::isfinite(white(a, a));
  for (int a = 0; a < offset; ++a)
    for (int b = 0; b < offset; ++b)
      if (undetermined[a] || undetermined[b]) white(a, b) = v(a, b) = 0;
  RaiseToFloor(white, &v);
  c.robust_sigma_ratio = Eigen::VectorXd::Constant(offset, NAN);
  for (int a = 0; a < offset; ++a) {
    if (undetermined[a]) {
      v.row(a).setConstant(NAN);
      v.col(a).setConstant(NAN);
      continue;
    }
    if (white(a, a) > 0) c.robust_sigma_ratio(a) = std::sqrt(v(a, a) / white(a, a));
  }
  c.analysis.covariance = v * (options.robust_sigma_factor * options.robust_sigma_factor);
  return c;
}

HeadCovarianceFloors FloorHeadCovariance(const HeadState& s,
                                         const models::RobotConfig& robot,
                                         const HeadFitOptions& options,
                                         HeadCovariance* c) {
  HeadCovariance& cov = *c;
  HeadCovarianceFloors out;
  if (options.hysteresis_sigma_floor_us > 0 && cov.analysis.ok) FloorHysteresis(s, options, &cov);
  if (options.fit_intrinsics && cov.analysis.ok) FloorIntrinsics(s, options, &cov);
  // The pan zero's sigma after its widening (the fused fit's floor, pipeline/calibrate_pipeline.cc).
  if (cov.analysis.ok)
    out.pan_zero_sigma_rad =
        WidenPanZero(s, robot, options.pan_zero_sigma_factor, options.pan_zero_sigma_floor_deg * M_PI / 180.0, &cov);
  if (options.fit_intrinsics && options.focal_scale_sigma_floor > 0 && cov.analysis.ok)
    out.focal_scale_sigma = FloorFocalScale(s, options.focal_scale_sigma_floor, &cov);
  if (options.fit_intrinsics && cov.analysis.ok) FloorPrincipalPoints(s, options, &cov);
  return out;
}

}  // namespace owlcal::fitting::internal
