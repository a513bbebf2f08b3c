// FitHead (fitting/head_fit.h) in four steps: build the problem (fitting/head_fit_setup.cc), solve
// it with outlier rejection (fitting/head_fit_solve.cc), the observability analysis and the
// covariance's floors (fitting/head_fit_covariance.cc), and the outputs (fitting/head_fit_output.cc);
// and the options' check.
#include "fitting/head_fit.h"

#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "fitting/head_problem.h"

namespace owlcal::fitting {
namespace {

using internal::HeadState;
using internal::PreparedView;

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

// The head's solver summary: the final solve's termination and cost, the whole solve's
// iterations, the residual statistics and the time so far.
void WriteHeadSummary(const internal::HeadSolveOutcome& solved,
                      const ResidualStatistics& stats,
                      const internal::StageTimer& timer,
                      HeadFit* out) {
  HeadFit& fit = *out;
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
}

// diagnostics.head: per view, the noise factor, the tag edge correction, the covariance's floors,
// its source and clusters, and the stage timings.
void WriteHeadDiagnostics(const HeadFitOptions& options,
                          const ResidualStatistics& stats,
                          const internal::HeadCovariance& cov,
                          const internal::HeadCovarianceFloors& floors,
                          const internal::StageTimer& timer,
                          HeadFit* out) {
  HeadFit& fit = *out;
  nlohmann::json& d = fit.result.diagnostics["head"];
  d["per_view"] = stats.per_view;
  d["num_views"] = fit.num_views_used;
  d["num_corners"] = stats.num_corners;
  d["noise_factor"] = stats.noise_factor;
  if (!options.tag_size_of_board.empty())
    d["tag_edge_correction"] = {{"corners", fit.num_tag_edge_corrected}, {"rms_px", fit.tag_edge_offset_rms_px}};
  if (std::isfinite(floors.pan_zero_sigma_rad))
    d["pan_zero"] = {{"sigma_deg", floors.pan_zero_sigma_rad * 180.0 / M_PI},
                     {"factor", options.pan_zero_sigma_factor},
                     {"floor_deg", options.pan_zero_sigma_floor_deg}};
  if (std::isfinite(floors.focal_scale_sigma))
    d["focal_scale_floor"] = {{"sigma_fitted", floors.focal_scale_sigma}, {"floor", options.focal_scale_sigma_floor}};
  d["null_space_dimension"] = cov.analysis.null_dimension;
  d["reciprocal_condition"] = cov.analysis.reciprocal_condition;
  d["covariance_source"] = cov.analysis.ok ? "fitting/observability.h: Schur complement of J^T J, boards eliminated"
                                           : "none: " + cov.analysis.message;
  if (options.covariance_clusters.kind != CovarianceClusters::Kind::kModel) {
    nlohmann::json r = {{"clusters", options.covariance_clusters.Spec()}, {"num_clusters", cov.num_clusters}};
    if (cov.robust_sigma_ratio.size() > 0) {
      d["covariance_source"] = "fitting/observability.h ClusterRobustCovariance: clustered by " +
                               options.covariance_clusters.Spec() + " (" + std::to_string(cov.num_clusters) +
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
}

}  // namespace

std::string CovarianceClusters::Spec() const {
  switch (kind) {
    case Kind::kModel:
      return "";
    case Kind::kView:
      return "view";
    case Kind::kPlacement:
      return "placement";
    case Kind::kCell: {
      std::ostringstream s;
      s << "cell:" << cell_us;
      return s.str();
    }
  }
  return "";
}

std::optional<CovarianceClusters> CovarianceClusters::Parse(const std::string& spec) {
  if (spec.empty() || spec == "model") return CovarianceClusters{};
  if (spec == "view") return CovarianceClusters{Kind::kView, 0};
  if (spec == "placement") return CovarianceClusters{Kind::kPlacement, 0};
  if (spec.rfind("cell:", 0) != 0) return std::nullopt;
  char* end = nullptr;
  const double b = std::strtod(spec.c_str() + 5, &end);
  if (end == spec.c_str() + 5 || *end != '\0' || !(b >= 1)) return std::nullopt;
  return Cell(b);
}

std::string FloorCarryName(FloorCarry carry) {
  switch (carry) {
    case FloorCarry::kNone:
      return "none";
    case FloorCarry::kCentres:
      return "centres";
    case FloorCarry::kServoMaps:
      return "servo_maps";
  }
  return "none";
}

std::optional<FloorCarry> ParseFloorCarry(const std::string& name) {
  for (const FloorCarry c : {FloorCarry::kNone, FloorCarry::kCentres, FloorCarry::kServoMaps})
    if (FloorCarryName(c) == name) return c;
  return std::nullopt;
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
  if (covariance_clusters.kind == CovarianceClusters::Kind::kCell && !(covariance_clusters.cell_us >= 1))
    return fail("covariance_clusters: a cell of " + std::to_string(covariance_clusters.cell_us) +
                " us; it must be >= 1 us");
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
  internal::StageTimer timer;
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
  std::vector<PreparedView> prepared =
      internal::PrepareViews(views, robot, options, &fit.result.warnings, &fit.result.notes);
  if (prepared.empty())
    return fail("head fit: no usable view (" + std::to_string(views.size()) + " given); nothing can be determined");
  const std::vector<std::string> classes = internal::AssignNoiseClasses(options, &prepared);
  HeadState s = internal::InitialState(initial, robot);
  internal::HoldWhatTheDataCannotDetermine(views, prepared, robot, options, &s);
  internal::InitialiseBoards(views, &prepared, &s, &fit.result.warnings);
  if (prepared.empty()) return fail("head fit: no board pose could be initialised (PnP failed for every target)");
  internal::InitialiseWarps(views, prepared, options, &s);

  // 2. Solve.
  std::unique_ptr<ceres::Problem> problem;
  const internal::HeadSolveOutcome solved =
      internal::SolveWithOutlierRejection(views, options, classes, &prepared, &s, &problem, &fit, &timer);
  const ResidualStatistics stats = ComputeResidualStatistics(views, prepared, s, fit, classes);
  fit.num_views_used = static_cast<int>(prepared.size());

  // 3. Observability and covariance.
  internal::HeadCovariance cov = internal::AnalyseHead(problem.get(), &s, views, options);
  const internal::HeadCovarianceFloors floors = internal::FloorHeadCovariance(s, robot, options, &cov);
  timer.Mark("covariance_s");

  // 4. Outputs.
  internal::WriteHeadOutputs(initial, robot, options, s, cov, views.size(), &fit);
  for (auto& w : RobotFileWarnings(CompareWithRobotFile(fit.result, robot, options.robot_file_tolerance)))
    fit.result.warnings.push_back(std::move(w));
  if (stats.noise_factor > 1.5)
    fit.result.warnings.push_back(
        "corner errors are " + std::to_string(stats.noise_factor) +
        " x corner_sigma_px: the model does not fit or the noise is larger; sigmas are too small");
  WriteHeadSummary(solved, stats, timer, &fit);
  WriteHeadDiagnostics(options, stats, cov, floors, timer, &fit);
  const SolveSummary& summary = fit.result.summaries.front();
  fit.ok = summary.usable;
  fit.message = summary.usable
                    ? "head fit: " + std::to_string(fit.num_views_used) + " views, " +
                          std::to_string(stats.num_corners) + " corners, RMS " + std::to_string(stats.rms_px) + " px"
                    : "head fit: solver failed: " + solved.final_summary.message;
  return fit;
}

}  // namespace owlcal::fitting
