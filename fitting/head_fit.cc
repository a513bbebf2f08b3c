#include "fitting/head_fit.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <string>

#include <ceres/ceres.h>
#include <Eigen/Dense>

#include "fitting/board_warp.h"
#include "fitting/head_problem.h"
#include "fitting/observability.h"

// FitHead in five steps: build the problem (fitting/head_fit_setup.cc), solve it with outlier
// rejection, the observability analysis of fitting/observability.h, and the outputs
// (fitting/head_fit_output.cc).
namespace owlcal::fitting {
namespace {

using internal::Block;
using internal::HeadState;
using internal::PreparedView;

// Stage timings for the diagnostics.
class StageTimer {
 public:
  StageTimer() : start_(std::chrono::steady_clock::now()), last_(start_) {}
  void Mark(const char* stage) {
    const auto now = std::chrono::steady_clock::now();
    timing_[stage] = std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }
  double TotalS() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  const nlohmann::json& Timing() const { return timing_; }

 private:
  std::chrono::steady_clock::time_point start_, last_;
  nlohmann::json timing_ = nlohmann::json::object();
};

struct HeadSolveOutcome {
  ceres::Solver::Summary final_summary;
  int iterations = 0;
  double initial_cost = 0;
};

// Inlier corners with finite errors per noise class and eye: sum of squares and count.
void SumSquaresPerClass(const HeadState& s,
                        const std::vector<PreparedView>& prepared,
                        size_t num_classes,
                        std::vector<std::array<double, 2>>* ssq,
                        std::vector<std::array<int, 2>>* count) {
  ssq->assign(num_classes, {0, 0});
  count->assign(num_classes, {0, 0});
  for (const PreparedView& p : prepared) {
    const std::vector<double> err = internal::CornerErrorsPx(s, p);
    for (size_t i = 0; i < err.size(); ++i) {
      if (!p.inlier[i] || !std::isfinite(err[i])) continue;
      (*ssq)[p.noise_class][p.command.eye] += err[i] * err[i];
      ++(*count)[p.noise_class][p.command.eye];
    }
  }
}

// The noise classes of the views (index 0: kDefaultNoiseClass, then the named classes in
// order); sets PreparedView::noise_class.
std::vector<std::string> AssignNoiseClasses(const HeadFitOptions& options, std::vector<PreparedView>* prepared) {
  std::vector<std::string> names = {kDefaultNoiseClass};
  for (const auto& [board, cls] : options.noise_class_of_board)
    if (std::find(names.begin(), names.end(), cls) == names.end()) names.push_back(cls);
  std::sort(names.begin() + 1, names.end());
  for (PreparedView& p : *prepared) {
    const auto it = options.noise_class_of_board.find(BoardOfTarget(p.target_id));
    const std::string& cls = it == options.noise_class_of_board.end() ? names[0] : it->second;
    p.noise_class = int(std::find(names.begin(), names.end(), cls) - names.begin());
  }
  return names;
}

// Whole views the model does not explain: a servo still moving when the frame was exposed, an
// eye held at its end-stop while the command moved on. Their corners agree with each other, so
// no single corner is an outlier, yet they pull every parameter (on variant A one such view pair
// at 10 x the typical RMS moved both camera mounts by 1.5 mm). Dropped and named.
void DropViewsTheModelDoesNotExplain(const std::vector<calib::View>& views,
                                     const HeadFitOptions& options,
                                     const HeadState& s,
                                     std::vector<PreparedView>* prepared,
                                     HeadFit* fit) {
  std::vector<double> view_rms(prepared->size(), 0.0);
  for (size_t k = 0; k < prepared->size(); ++k) {
    const std::vector<double> err = internal::CornerErrorsPx(s, (*prepared)[k]);
    double ss = 0;
    int n = 0;
    for (size_t i = 0; i < err.size(); ++i)
      if ((*prepared)[k].inlier[i] && std::isfinite(err[i])) ss += err[i] * err[i], ++n;
    view_rms[k] = n ? std::sqrt(ss / n) : 0.0;
  }
  std::vector<double> sorted = view_rms;
  std::sort(sorted.begin(), sorted.end());
  const double median = sorted.empty() ? 0.0 : sorted[sorted.size() / 2];
  for (size_t k = 0; k < prepared->size(); ++k) {
    if (!(median > 0) || view_rms[k] <= options.view_outlier_factor * median) continue;
    PreparedView& p = (*prepared)[k];
    const calib::View& v = views[p.index];
    const std::vector<double> err = internal::CornerErrorsPx(s, p);
    for (size_t i = 0; i < err.size(); ++i) {
      if (!p.inlier[i]) continue;
      p.inlier[i] = false;
      fit->outliers.push_back({v.frame_index, v.eye, v.target_id, p.corner_ids[i], err[i]});
    }
    std::ostringstream w;
    w.precision(3);
    w << "frame " << v.frame_index << " (" << models::kEyeNames[v.eye] << ", " << v.target_id << "): RMS "
      << view_rms[k] << " px, " << view_rms[k] / median
      << " x the median view's; the model does not explain it (a servo still moving, an eye at its end-stop?): dropped";
    fit->result.warnings.push_back(w.str());
  }
}

// Stage 1: robust solve on a spread subset of corners; rejection of corners beyond
// outlier_threshold_sigma and of whole views the model does not explain; stage 2: plain solve on
// every inlier (its Jacobian is the one the observability analysis reads), whitened again with
// the measured noise when options.estimate_corner_sigma. Blocks no residual involves are marked
// not determined.
HeadSolveOutcome SolveWithOutlierRejection(const std::vector<calib::View>& views,
                                           const HeadFitOptions& options,
                                           const std::vector<std::string>& classes,
                                           std::vector<PreparedView>* prepared,
                                           HeadState* s,
                                           std::unique_ptr<ceres::Problem>* problem,
                                           HeadFit* fit,
                                           StageTimer* timer) {
  const double sigma = options.corner_sigma_px;
  // Each class's widening for errors its views share (HeadFitOptions::sigma_factor_of_class).
  std::vector<double> class_factor(classes.size(), 1.0);
  for (size_t k = 0; k < classes.size(); ++k)
    if (const auto it = options.sigma_factor_of_class.find(classes[k]); it != options.sigma_factor_of_class.end())
      class_factor[k] = it->second;
  std::vector<std::array<double, 2>> class_sigma(classes.size(), {sigma, sigma});
  HeadSolveOutcome out;
  {
    ceres::Problem robust;
    // Every corner is not needed to reach the basin: a spread subset per view is 3-5 x faster.
    internal::BuildHeadProblem(s, *prepared, class_sigma, options.huber_sigma, options, 12, &robust);
    // Loose tolerance: this stage only has to find the basin and the outliers.
    const ceres::Solver::Summary s1 = internal::SolveHeadProblem(&robust, options, 1e-7);
    out.iterations += static_cast<int>(s1.iterations.size());
    out.initial_cost = s1.initial_cost;
  }
  timer->Mark("solve_robust_s");
  if (!options.tag_size_of_board.empty()) {
    // Tag corners against the detector's straight-edge corners at the robust solution (the
    // correction changes with the parameters only at second order).
    fit->num_tag_edge_corrected = internal::CorrectTagEdgeCorners(*s, options, prepared);
    double ss = 0;
    for (const PreparedView& p : *prepared)
      for (const Eigen::Vector2d& d : p.edge_offset) ss += d.squaredNorm();
    fit->tag_edge_offset_rms_px = fit->num_tag_edge_corrected ? std::sqrt(ss / fit->num_tag_edge_corrected) : 0.0;
  }
  if (options.outlier_threshold_sigma > 0) {
    for (PreparedView& p : *prepared) {
      const std::vector<double> err = internal::CornerErrorsPx(*s, p);
      for (size_t i = 0; i < err.size(); ++i) {
        if (std::isfinite(err[i]) && err[i] <= options.outlier_threshold_sigma * sigma) continue;
        p.inlier[i] = false;
        const calib::View& v = views[p.index];
        fit->outliers.push_back({v.frame_index, v.eye, v.target_id, p.corner_ids[i], err[i]});
      }
    }
  }
  if (options.view_outlier_factor > 0) DropViewsTheModelDoesNotExplain(views, options, *s, prepared, fit);
  // The classes' widening from the final solve on (the robust stage only finds the basin and the
  // outliers, at the plain sigma).
  for (size_t k = 0; k < classes.size(); ++k)
    for (double& c : class_sigma[k]) c *= class_factor[k];
  *problem = std::make_unique<ceres::Problem>();
  fit->num_corners_used = internal::BuildHeadProblem(s, *prepared, class_sigma, 0.0, options, 0, problem->get());
  out.final_summary = internal::SolveHeadProblem(problem->get(), options, 1e-12);
  out.iterations += static_cast<int>(out.final_summary.iterations.size());
  timer->Mark("solve_final_s");
  std::vector<std::array<double, 2>> measured(classes.size(), {0, 0});
  if (options.estimate_corner_sigma) {
    // Each noise class's sigma per eye and axis from its own residuals, the sum of squares
    // shared over 2N - p degrees of freedom (p: the free parameters, boards included). The
    // relative weights of the eyes and classes (and of an intrinsics prior) change, so solve again.
    std::vector<std::array<double, 2>> ssq;
    std::vector<std::array<int, 2>> count;
    SumSquaresPerClass(*s, *prepared, classes.size(), &ssq, &count);
    int num_free = 0;
    for (Block* b : s->HeadBlocks())
      if (b->in_problem) num_free += b->TangentSize();
    for (Block* b : s->BoardBlocks())
      if (b->in_problem) num_free += b->TangentSize();
    int num_residuals = 0;
    for (const auto& c : count) num_residuals += 2 * (c[0] + c[1]);
    bool changed = false;
    for (size_t k = 0; k < classes.size() && num_residuals > num_free; ++k) {
      for (int e = 0; e < 2; ++e) {
        if (count[k][e] == 0) continue;
        const double dof = double(num_residuals) / (num_residuals - num_free);
        measured[k][e] = std::sqrt(ssq[k][e] / (2.0 * count[k][e]) * dof);
        const double use =
            std::max(options.measured_sigma_factor * measured[k][e], options.min_corner_sigma_px) * class_factor[k];
        changed |= std::abs(use - class_sigma[k][e]) > 1e-3 * class_sigma[k][e];
        if (use > 0) class_sigma[k][e] = use;
      }
    }
    if (changed) {
      *problem = std::make_unique<ceres::Problem>();
      internal::BuildHeadProblem(s, *prepared, class_sigma, 0.0, options, 0, problem->get());
      out.final_summary = internal::SolveHeadProblem(problem->get(), options, 1e-12);
      out.iterations += static_cast<int>(out.final_summary.iterations.size());
      timer->Mark("solve_whitened_s");
    }
  }
  {
    std::vector<std::array<double, 2>> ssq;
    std::vector<std::array<int, 2>> count;
    SumSquaresPerClass(*s, *prepared, classes.size(), &ssq, &count);
    size_t main_class = classes.size();
    for (size_t k = 0; k < classes.size(); ++k) {
      if (count[k][0] + count[k][1] == 0) continue;
      if (main_class == classes.size()) main_class = k;
      HeadFit::NoiseClass& c = fit->noise_classes[classes[k]];
      c.sigma_px = class_sigma[k];
      c.measured_sigma_px = measured[k];
      c.num_corners = count[k];
    }
    if (main_class == classes.size()) main_class = 0;
    for (int e = 0; e < 2; ++e) {
      fit->corner_sigma_px[e] = class_sigma[main_class][e];
      fit->measured_corner_sigma_px[e] = measured[main_class][e];
    }
  }
  auto mark_unused = [](Block& b, const std::string& what) {
    if (!b.in_problem) b.FixAll("not determined: no usable view involves " + what);
  };
  for (int i = 0; i < models::kNumServos; ++i) mark_unused(s->servo[i], std::string("servo ") + models::kServoNames[i]);
  for (int e = 0; e < 2; ++e) {
    mark_unused(s->mount[e], std::string("the ") + models::kEyeNames[e] + " camera");
    mark_unused(s->camera[e], std::string("the ") + models::kEyeNames[e] + " camera");
  }
  return out;
}

struct ResidualStatistics {
  int num_corners = 0;
  double rms_px = 0;
  double noise_factor = 0;  // per-axis RMS / the whitening sigma (RMS over the eyes)
  nlohmann::json per_view = nlohmann::json::array();
};

ResidualStatistics ComputeResidualStatistics(const std::vector<calib::View>& views,
                                             const std::vector<PreparedView>& prepared,
                                             const HeadState& s,
                                             const HeadFit& fit,
                                             const std::vector<std::string>& classes) {
  ResidualStatistics r;
  double sum_sq = 0, sum_whitened = 0;
  for (const PreparedView& p : prepared) {
    const std::vector<double> err = internal::CornerErrorsPx(s, p);
    const auto cls = fit.noise_classes.find(classes[p.noise_class]);
    const double sigma = cls == fit.noise_classes.end() ? 0.0 : cls->second.sigma_px[p.command.eye];
    double vs = 0;
    int vn = 0;
    for (size_t i = 0; i < err.size(); ++i) {
      if (!p.inlier[i] || !std::isfinite(err[i])) continue;
      vs += err[i] * err[i];
      ++vn;
    }
    sum_sq += vs;
    if (sigma > 0) sum_whitened += vs / (sigma * sigma);
    r.num_corners += vn;
    const calib::View& v = views[p.index];
    r.per_view.push_back({{"frame", v.frame_index},
                          {"eye", models::kEyeNames[v.eye]},
                          {"target", v.target_id},
                          {"corners", vn},
                          {"rms_px", vn ? std::sqrt(vs / vn) : 0.0}});
  }
  r.rms_px = r.num_corners ? std::sqrt(sum_sq / r.num_corners) : 0.0;
  // Per-axis RMS of the whitened errors: 1 when every class's sigma is its noise.
  r.noise_factor = r.num_corners ? std::sqrt(sum_whitened / (2.0 * r.num_corners)) : 0.0;
  return r;
}

// The observability analysis over the free head blocks with the boards eliminated.
internal::HeadCovariance AnalyseHead(ceres::Problem* problem,
                                     HeadState* s,
                                     const std::vector<calib::View>& views,
                                     const HeadFitOptions& options) {
  internal::HeadCovariance c;
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
  if (options.covariance_clusters.empty() || !c.analysis.ok) return c;
  // The covariance the residuals show, clustered (HeadFitOptions::covariance_clusters), never
  // below white noise at the measured sigma.
  auto sandwich = [&](const std::string& spec) {
    // "view": one residual block per view; "placement": the views of one board placement by one
    // eye; "cell:B": the views of one board placement whose five commands fall in the same B us
    // cell (both eyes' views of a frame together).
    const double cell_us = HeadFitOptions::CellOfClusters(spec);
    std::map<std::pair<const double*, const double*>, int> placement;
    std::map<ceres::ResidualBlockId, int> view_index;
    std::map<std::pair<const double*, std::array<long, models::kNumServos>>, int> cell;
    auto cluster_of = [&](ceres::ResidualBlockId id) {
      std::vector<double*> blocks;
      problem->GetParameterBlocksForResidualBlock(id, &blocks);
      if (blocks.size() != 8) return -1;  // a prior
      if (spec == "view") return view_index.try_emplace(id, int(view_index.size())).first->second;
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

// HeadFitOptions::pan_zero_sigma_factor: C += (factor^2 - 1) var(g) w w^T / (a^T w)^2, with g = a^T x
// the two pan maps' mean angle at the robot file's centres and w the tangent direction that shifts
// both pan maps by one angle (fitting/head_gauge.h ShiftServoMapAngle), so g's sigma grows by the
// factor and every other parameter keeps its own. Coordinates without a finite variance (held or
// undetermined) take no part. With floor_rad > 0 the factor is at least floor_rad / sigma(g)
// (pan_zero_sigma_floor_deg). Returns g's sigma after [rad] (NaN when it has none).
double WidenPanZero(const HeadState& s,
                    const models::RobotConfig& robot,
                    double factor,
                    double floor_rad,
                    internal::HeadCovariance* cov) {
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
double FloorFocalScale(const HeadState& s, double floor, internal::HeadCovariance* cov) {
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
void FloorPrincipalPoints(const HeadState& s, const HeadFitOptions& options, internal::HeadCovariance* cov) {
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

}  // namespace

double HeadFitOptions::CellOfClusters(const std::string& spec) {
  if (spec.rfind("cell:", 0) != 0) return 0.0;
  char* end = nullptr;
  const double b = std::strtod(spec.c_str() + 5, &end);
  return end != spec.c_str() + 5 && *end == '\0' && b >= 1 ? b : NAN;
}

bool HeadFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "HeadFitOptions: " + m;
    return false;
  };
  if (!(corner_sigma_px > 0)) return fail("corner_sigma_px = " + std::to_string(corner_sigma_px) + " must be > 0");
  if (std::string w; !robot_file_tolerance.Check(&w)) return fail(w);
  if (!(min_corner_sigma_px >= 0 && min_corner_sigma_px < 10))
    return fail("min_corner_sigma_px = " + std::to_string(min_corner_sigma_px) + " must be in [0, 10)");
  if (!(measured_sigma_factor >= 1 && measured_sigma_factor <= 10))
    return fail("measured_sigma_factor = " + std::to_string(measured_sigma_factor) + " must be in [1, 10]");
  if (!(covariance_clusters.empty() || covariance_clusters == "view" || covariance_clusters == "placement" ||
        CellOfClusters(covariance_clusters) >= 1))
    return fail("covariance_clusters = '" + covariance_clusters +
                "' must be empty, view, placement or cell:B with B >= 1 us");
  for (int e = 0; e < 2; ++e) {
    const auto& f = principal_point_covariance_floor[e];
    if (f && (f->rows() != 2 || f->cols() != 2 || !f->allFinite() || !((*f)(0, 0) >= 0) || !((*f)(1, 1) >= 0)))
      return fail("principal_point_covariance_floor[" + std::to_string(e) +
                  "] must be a finite 2 x 2 covariance (cx, cy) [px^2]");
  }
  if (!(pan_zero_sigma_floor_deg >= 0 && pan_zero_sigma_floor_deg < 10))
    return fail("pan_zero_sigma_floor_deg = " + std::to_string(pan_zero_sigma_floor_deg) + " must be in [0, 10)");
  if (!(focal_scale_sigma_floor >= 0 && focal_scale_sigma_floor < 0.1))
    return fail("focal_scale_sigma_floor = " + std::to_string(focal_scale_sigma_floor) + " must be in [0, 0.1)");
  if (!(pan_zero_sigma_factor >= 1 && pan_zero_sigma_factor < 100))
    return fail("pan_zero_sigma_factor = " + std::to_string(pan_zero_sigma_factor) + " must be in [1, 100)");
  if (intrinsics_floor_carry != "none" && intrinsics_floor_carry != "centres" && intrinsics_floor_carry != "servo_maps")
    return fail("intrinsics_floor_carry = '" + intrinsics_floor_carry + "' must be none, centres or servo_maps");
  if (!(hysteresis_sigma_floor_us >= 0 && hysteresis_sigma_floor_us < 100))
    return fail("hysteresis_sigma_floor_us = " + std::to_string(hysteresis_sigma_floor_us) + " must be in [0, 100)");
  if (!(view_outlier_factor == 0 || view_outlier_factor >= 1.5))
    return fail("view_outlier_factor = " + std::to_string(view_outlier_factor) + " must be 0 (off) or >= 1.5");
  if (huber_sigma < 0) return fail("huber_sigma = " + std::to_string(huber_sigma) + " must be >= 0");
  if (outlier_threshold_sigma < 0)
    return fail("outlier_threshold_sigma = " + std::to_string(outlier_threshold_sigma) + " must be >= 0");
  if (min_corners_per_view < 3)
    return fail("min_corners_per_view = " + std::to_string(min_corners_per_view) + " must be >= 3");
  if (max_iterations < 1) return fail("max_iterations = " + std::to_string(max_iterations) + " must be >= 1");
  if (!(rank_tolerance > 0 && rank_tolerance < 1))
    return fail("rank_tolerance = " + std::to_string(rank_tolerance) + " must be in (0, 1)");
  if (num_threads < 1) return fail("num_threads = " + std::to_string(num_threads) + " must be >= 1");
  for (const auto& [board, size] : tag_size_of_board)
    if (board.empty() || !(size > 0 && size < 10))
      return fail("tag_size_of_board: board '" + board + "' -> " + std::to_string(size) +
                  " m: a named board and a tag size in (0, 10) m");
  for (const auto& [cls, factor] : sigma_factor_of_class)
    if (cls.empty() || !(factor >= 1 && factor < 100))
      return fail("sigma_factor_of_class: class '" + cls + "' -> " + std::to_string(factor) +
                  ": a named class and a factor in [1, 100)");
  for (const auto& [board, cls] : noise_class_of_board)
    if (board.empty() || cls.empty())
      return fail("noise_class_of_board: board '" + board + "' -> class '" + cls + "': names must not be empty");
  return true;
}

HeadFit FitHead(const std::vector<calib::View>& views,
                const models::RobotConfig& robot,
                const models::HeadModel& initial,
                const HeadFitOptions& options) {
  StageTimer timer;
  HeadFit fit;
  fit.result.summaries.push_back({});
  fit.result.summaries.back().problem = "head";
  auto fail = [&](const std::string& message) {
    fit.ok = false;
    fit.message = message;
    fit.result.summaries.back().message = message;
    fit.result.summaries.back().usable = false;
    fit.result.warnings.push_back(message);
    return fit;
  };
  std::string why;
  if (!options.Check(&why)) return fail(why);
  for (int e = 0; e < 2; ++e) {
    const auto& c = initial.intrinsics[e];
    if (static_cast<int>(c.params.size()) != 4 + c.NumDistortion())
      return fail(std::string("initial head: ") + models::kEyeNames[e] + " camera params has " +
                  std::to_string(c.params.size()) + " values, model needs " + std::to_string(4 + c.NumDistortion()));
  }

  // 1. Build: views, initial blocks, what the data cannot determine, board poses.
  std::vector<PreparedView> prepared = internal::PrepareViews(views, robot, options, &fit.result.warnings);
  if (prepared.empty())
    return fail("head fit: no usable view (" + std::to_string(views.size()) + " given); nothing can be determined");
  const std::vector<std::string> classes = AssignNoiseClasses(options, &prepared);
  HeadState s = internal::InitialState(initial, robot);
  internal::HoldWhatTheDataCannotDetermine(views, prepared, robot, options, &s);
  internal::InitialiseBoards(views, &prepared, &s, &fit.result.warnings);
  if (prepared.empty()) return fail("head fit: no board pose could be initialised (PnP failed for every target)");
  internal::InitialiseWarps(views, prepared, options, &s);

  // 2. Solve.
  std::unique_ptr<ceres::Problem> problem;
  const HeadSolveOutcome solved =
      SolveWithOutlierRejection(views, options, classes, &prepared, &s, &problem, &fit, &timer);
  const ResidualStatistics stats = ComputeResidualStatistics(views, prepared, s, fit, classes);
  fit.num_views_used = static_cast<int>(prepared.size());

  // 3. Observability and covariance.
  internal::HeadCovariance cov = AnalyseHead(problem.get(), &s, views, options);
  if (options.hysteresis_sigma_floor_us > 0 && cov.analysis.ok) {
    // Raising a diagonal entry keeps the covariance positive semi-definite.
    for (const Block& b : s.servo) {
      auto it = cov.tangent_of.find({&b, 4});  // hysteresis_us
      if (it == cov.tangent_of.end() || !(b.scale[4] > 0)) continue;
      const double floor = options.hysteresis_sigma_floor_us / b.scale[4];
      double& v = cov.analysis.covariance(it->second, it->second);
      v = std::max(v, floor * floor);
    }
  }
  if (options.fit_intrinsics && cov.analysis.ok) {
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
      if (options.intrinsics_floor_carry != "none") {
        for (const Block& servo : s.servo) {
          for (int a = 0; a < servo.size(); ++a) {
            if (a != 0 && options.intrinsics_floor_carry == "centres") continue;  // 0: centre_us
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
  // The pan zero's sigma after its widening (the fused fit's floor, pipeline/calibrate_pipeline.cc).
  double pan_zero_sigma_rad = NAN;
  if (cov.analysis.ok)
    pan_zero_sigma_rad =
        WidenPanZero(s, robot, options.pan_zero_sigma_factor, options.pan_zero_sigma_floor_deg * M_PI / 180.0, &cov);
  double focal_scale_sigma = NAN;
  if (options.fit_intrinsics && options.focal_scale_sigma_floor > 0 && cov.analysis.ok)
    focal_scale_sigma = FloorFocalScale(s, options.focal_scale_sigma_floor, &cov);
  if (options.fit_intrinsics && cov.analysis.ok) FloorPrincipalPoints(s, options, &cov);
  timer.Mark("covariance_s");

  // 4. Outputs.
  internal::WriteHeadOutputs(initial, robot, options, s, cov, views.size(), &fit);
  for (auto& w : RobotFileWarnings(CompareWithRobotFile(fit.result, robot, options.robot_file_tolerance)))
    fit.result.warnings.push_back(std::move(w));
  if (stats.noise_factor > 1.5)
    fit.result.warnings.push_back(
        "corner errors are " + std::to_string(stats.noise_factor) +
        " x corner_sigma_px: the model does not fit or the noise is larger; sigmas are too small");
  SolveSummary& summary = fit.result.summaries.front();
  const ceres::Solver::Summary& s2 = solved.final_summary;
  summary.termination = ceres::TerminationTypeToString(s2.termination_type);
  summary.message = s2.message;
  summary.initial_cost = solved.initial_cost;
  summary.final_cost = s2.final_cost;
  summary.iterations = solved.iterations;
  summary.rms_px = stats.rms_px;
  summary.num_residuals = 2 * stats.num_corners;
  summary.num_outliers = static_cast<int>(fit.outliers.size());
  summary.usable = s2.IsSolutionUsable();
  summary.time_s = timer.TotalS();
  nlohmann::json& d = fit.result.diagnostics["head"];
  d["per_view"] = stats.per_view;
  d["num_views"] = fit.num_views_used;
  d["num_corners"] = stats.num_corners;
  d["noise_factor"] = stats.noise_factor;
  if (!options.tag_size_of_board.empty())
    d["tag_edge_correction"] = {{"corners", fit.num_tag_edge_corrected}, {"rms_px", fit.tag_edge_offset_rms_px}};
  if (std::isfinite(pan_zero_sigma_rad))
    d["pan_zero"] = {{"sigma_deg", pan_zero_sigma_rad * 180.0 / M_PI},
                     {"factor", options.pan_zero_sigma_factor},
                     {"floor_deg", options.pan_zero_sigma_floor_deg}};
  if (std::isfinite(focal_scale_sigma))
    d["focal_scale_floor"] = {{"sigma_fitted", focal_scale_sigma}, {"floor", options.focal_scale_sigma_floor}};
  d["null_space_dimension"] = cov.analysis.null_dimension;
  d["reciprocal_condition"] = cov.analysis.reciprocal_condition;
  d["covariance_source"] = cov.analysis.ok ? "fitting/observability.h: Schur complement of J^T J, boards eliminated"
                                           : "none: " + cov.analysis.message;
  if (!options.covariance_clusters.empty()) {
    nlohmann::json r = {{"clusters", options.covariance_clusters}, {"num_clusters", cov.num_clusters}};
    if (cov.robust_sigma_ratio.size() > 0) {
      d["covariance_source"] = "fitting/observability.h ClusterRobustCovariance: clustered by " +
                               options.covariance_clusters + " (" + std::to_string(cov.num_clusters) +
                               "), never below white noise at the measured sigma, x " +
                               std::to_string(options.robust_sigma_factor) + " for the bias every view shares";
      nlohmann::json ratio = nlohmann::json::object();
      for (int a = 0; a < cov.robust_sigma_ratio.size(); ++a)
        if (std::isfinite(cov.robust_sigma_ratio(a))) ratio[cov.names.at(a)] = cov.robust_sigma_ratio(a);
      r["sigma_over_white"] = ratio;
      r["robust_sigma_factor"] = options.robust_sigma_factor;
    } else {
      r["message"] = cov.clusters_message;
    }
    d["cluster_robust"] = r;
  }
  d["timing"] = timer.Timing();
  fit.ok = summary.usable;
  fit.message = summary.usable
                    ? "head fit: " + std::to_string(fit.num_views_used) + " views, " +
                          std::to_string(stats.num_corners) + " corners, RMS " + std::to_string(stats.rms_px) + " px"
                    : "head fit: solver failed: " + s2.message;
  return fit;
}

}  // namespace owlcal::fitting
