// The solve of FitHead (declared in fitting/head_problem.h): the noise classes, a robust solve
// on a subset of corners, the rejection of corner outliers and of whole views the model does not
// explain, the final solve on every inlier, and its re-whitening with the measured noise.
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <ceres/ceres.h>

#include "fitting/board_warp.h"
#include "fitting/head_problem.h"

namespace owlcal::fitting::internal {
namespace {

// Inlier corners with finite errors per noise class and eye: sum of squares and count.
void SumSquaresPerClass(const HeadState& s,
                        const std::vector<PreparedView>& prepared,
                        size_t num_classes,
                        std::vector<std::array<double, 2>>* ssq,
                        std::vector<std::array<int, 2>>* count) {
  ssq->assign(num_classes, {0, 0});
  count->assign(num_classes, {0, 0});
  for (const PreparedView& p : prepared) {
    const std::vector<double> err = CornerErrorsPx(s, p);
    for (size_t i = 0; i < err.size(); ++i) {
      if (!p.inlier[i] || !std::isfinite(err[i])) continue;
      (*ssq)[p.noise_class][p.command.eye] += err[i] * err[i];
      ++(*count)[p.noise_class][p.command.eye];
    }
  }
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
    const std::vector<double> err = CornerErrorsPx(s, (*prepared)[k]);
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
    const std::vector<double> err = CornerErrorsPx(s, p);
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

}  // namespace

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
    BuildHeadProblem(s, *prepared, class_sigma, options.huber_sigma, options, 12, &robust);
    // Loose tolerance: this stage only has to find the basin and the outliers.
    const ceres::Solver::Summary s1 = SolveHeadProblem(&robust, options, 1e-7);
    out.iterations += static_cast<int>(s1.iterations.size());
    out.initial_cost = s1.initial_cost;
  }
  timer->Mark("solve_robust_s");
  if (!options.tag_size_of_board.empty()) {
    // Tag corners against the detector's straight-edge corners at the robust solution (the
    // correction changes with the parameters only at second order).
    fit->num_tag_edge_corrected = CorrectTagEdgeCorners(*s, options, prepared);
    double ss = 0;
    for (const PreparedView& p : *prepared)
      for (const Eigen::Vector2d& d : p.edge_offset) ss += d.squaredNorm();
    fit->tag_edge_offset_rms_px = fit->num_tag_edge_corrected ? std::sqrt(ss / fit->num_tag_edge_corrected) : 0.0;
  }
  if (options.outlier_threshold_sigma > 0) {
    for (PreparedView& p : *prepared) {
      const std::vector<double> err = CornerErrorsPx(*s, p);
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
  fit->num_corners_used = BuildHeadProblem(s, *prepared, class_sigma, 0.0, options, 0, problem->get());
  out.final_summary = SolveHeadProblem(problem->get(), options, 1e-12);
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
      BuildHeadProblem(s, *prepared, class_sigma, 0.0, options, 0, problem->get());
      out.final_summary = SolveHeadProblem(problem->get(), options, 1e-12);
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

}  // namespace owlcal::fitting::internal
