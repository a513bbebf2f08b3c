#include "evaluation/range_scale_budget.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Core>

#include "fitting/format.h"

namespace owlcal::evaluation {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// b of the datum fit with the rows' ranges replaced by `ranges` (same sigmas and truths); NaN
// when the fit fails.
double RefitB(const std::vector<RangeMeasurement>& rows,
              const std::vector<int>& fit_rows,
              const std::vector<double>& ranges) {
  std::vector<fitting::DatumFitRow> d;
  for (size_t k = 0; k < fit_rows.size(); ++k) {
    const RangeMeasurement& m = rows[fit_rows[k]];
    d.push_back({ranges[k], m.true_m, m.sigma_m, m.truth_sigma_m});
  }
  const fitting::DatumFit f = fitting::FitDatum(d);
  return f.ok ? f.b : kNaN;
}

// The fit rows' ranges for the rig's parameters p, their raw pixels held (NaN-free or empty).
std::vector<double> RangesFor(const std::vector<RangeMeasurement>& rows,
                              const std::vector<int>& fit_rows,
                              const std::vector<double>& offsets,
                              const fitting::StereoRig& rig,
                              const std::vector<double>& p,
                              const Eigen::Vector3d& axis) {
  std::vector<double> r;
  for (size_t k = 0; k < fit_rows.size(); ++k) {
    const RangeMeasurement& m = rows[fit_rows[k]];
    const auto z = TriangulateDepth(rig, p, m.raw_px[0], m.raw_px[1], axis);
    if (!z) return {};
    r.push_back(*z + offsets[k]);
  }
  return r;
}

// The fit rows' ranges with every rectified disparity replaced by disparity(k) (NaN: kept).
template <typename DisparityFn>
std::vector<double> RangesWithDisparity(const std::vector<RangeMeasurement>& rows,
                                        const std::vector<int>& fit_rows,
                                        const std::vector<double>& offsets,
                                        const fitting::StereoRig& rig,
                                        const fitting::Rectification& rect,
                                        DisparityFn disparity) {
  std::vector<double> r;
  for (size_t k = 0; k < fit_rows.size(); ++k) {
    const RangeMeasurement& m = rows[fit_rows[k]];
    const double d = disparity(k);
    if (!std::isfinite(d)) {
      r.push_back(m.range_m);
      continue;
    }
    const cv::Point2d right(m.match.left_px.x - d, m.match.right_px.y);
    const RectifiedTriangulation t = TriangulateRectified(rig, rect, m.match.left_px, right);
    if (!t.ok) return {};
    r.push_back(t.depth_m + offsets[k]);
  }
  return r;
}

void CalibrationTerm(const std::vector<RangeMeasurement>& rows,
                     const std::vector<int>& fit_rows,
                     const std::vector<double>& offsets,
                     const fitting::StereoRig& rig,
                     const Eigen::Vector3d& axis,
                     ScaleBudget* s) {
  const int n = rig.NumParams();
  const std::vector<double> p0 = fitting::RigParameters(rig);
  s->calib_sigma_cov = kNaN;
  if (rig.covariance.rows() == n && rig.covariance.cols() == n) {
    Eigen::VectorXd J = Eigen::VectorXd::Zero(n);
    bool all = true;
    for (int i = 0; i < n && all; ++i) {
      const double var = rig.covariance(i, i);
      if (!(var > 0)) continue;
      const double h = 0.01 * std::sqrt(var);
      std::vector<double> pp = p0, pm = p0;
      pp[i] += h;
      pm[i] -= h;
      const auto rp = RangesFor(rows, fit_rows, offsets, rig, pp, axis);
      const auto rm = RangesFor(rows, fit_rows, offsets, rig, pm, axis);
      const double bp = rp.empty() ? kNaN : RefitB(rows, fit_rows, rp);
      const double bm = rm.empty() ? kNaN : RefitB(rows, fit_rows, rm);
      all = std::isfinite(bp) && std::isfinite(bm);
      if (all) J[i] = (bp - bm) / (2 * h);
    }
    if (all)
      s->calib_sigma_cov = std::sqrt(std::max(0.0, J.dot(rig.covariance * J)));
    else
      s->notes.push_back("calibration sigma not computed: a perturbed calibration failed to triangulate a row");
  } else {
    s->notes.push_back("the calibration has no covariance (an OpenCV file?): its sigma is unknown");
  }
  s->calib_sigma_cv = kNaN;
  if (rig.halves.size() == 2) {
    const auto ra = RangesFor(rows, fit_rows, offsets, rig, rig.halves[0], axis);
    const auto rb = RangesFor(rows, fit_rows, offsets, rig, rig.halves[1], axis);
    const double ba = ra.empty() ? kNaN : RefitB(rows, fit_rows, ra);
    const double bb = rb.empty() ? kNaN : RefitB(rows, fit_rows, rb);
    if (std::isfinite(ba) && std::isfinite(bb)) s->calib_sigma_cv = std::abs(ba - bb) / 2;
  } else {
    s->notes.push_back("no halves of the calibration set: sigma_cv unknown");
  }
}

}  // namespace

ScaleBudget SplitScale(const std::vector<RangeMeasurement>& rows,
                       const std::vector<int>& fit_rows,
                       const fitting::DatumFit& fit,
                       const fitting::StereoRig& rig,
                       const fitting::Rectification& rect,
                       const std::vector<double>& second_disparity_px,
                       double subpixel_floor_px) {
  ScaleBudget s;
  s.num_rows = static_cast<int>(fit_rows.size());
  if (!fit.ok) {
    s.message = "no datum fit: " + fit.message;
    return s;
  }
  if (second_disparity_px.size() != rows.size()) {
    s.message = "second matcher's disparities do not match the rows";
    return s;
  }
  s.b_minus_1 = fit.b - 1;
  s.sigma_b = fit.sigma_b;
  const cv::Vec3d ax = rect.R1.t() * cv::Vec3d(0, 0, 1);
  const Eigen::Vector3d axis(ax[0], ax[1], ax[2]);
  // Each row's datum offset (range - depth from the optical centres).
  std::vector<double> offsets;
  const std::vector<double> p0 = fitting::RigParameters(rig);
  for (int i : fit_rows) {
    const auto z = TriangulateDepth(rig, p0, rows[i].raw_px[0], rows[i].raw_px[1], axis);
    if (!z) {
      s.message = rows[i].name + ": the calibration does not triangulate its match";
      return s;
    }
    offsets.push_back(rows[i].range_m - *z);
  }
  CalibrationTerm(rows, fit_rows, offsets, rig, axis, &s);

  // Matching: a common disparity bias (its derivative), and the second matcher's disparities.
  const double h = 0.1;
  const auto rp = RangesWithDisparity(
      rows, fit_rows, offsets, rig, rect, [&](size_t k) { return rows[fit_rows[k]].match.disparity_px + h; });
  const auto rm = RangesWithDisparity(
      rows, fit_rows, offsets, rig, rect, [&](size_t k) { return rows[fit_rows[k]].match.disparity_px - h; });
  const double bp = rp.empty() ? kNaN : RefitB(rows, fit_rows, rp), bm = rm.empty() ? kNaN : RefitB(rows, fit_rows, rm);
  s.db_dd_per_px = (bp - bm) / (2 * h);
  s.subpixel_floor_px = subpixel_floor_px;
  s.matching_sigma = std::abs(s.db_dd_per_px) * subpixel_floor_px;
  for (int i : fit_rows) s.matching_rows += std::isfinite(second_disparity_px[i]);
  s.matching = kNaN;
  if (s.matching_rows * 2 > s.num_rows) {
    const auto r2 = RangesWithDisparity(
        rows, fit_rows, offsets, rig, rect, [&](size_t k) { return second_disparity_px[fit_rows[k]]; });
    if (!r2.empty()) s.matching = RefitB(rows, fit_rows, r2) - fit.b;
    if (s.matching_rows < s.num_rows)
      s.notes.push_back("the second matcher measured " + std::to_string(s.matching_rows) + " of " +
                        std::to_string(s.num_rows) + " rows (the others kept their own disparity)");
  } else {
    s.notes.push_back("the second matcher measured only " + std::to_string(s.matching_rows) + " of " +
                      std::to_string(s.num_rows) + " rows: matching term not computed");
  }
  s.truth = s.b_minus_1 - (std::isfinite(s.matching) ? s.matching : 0.0);
  s.truth_sigma = s.sigma_b;
  s.ok = std::isfinite(s.db_dd_per_px);
  if (!s.ok) s.message = "a shifted disparity did not triangulate";
  return s;
}

nlohmann::json ScaleBudgetToJson(const ScaleBudget& b) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  return {{"ok", b.ok},
          {"message", b.message},
          {"num_rows", b.num_rows},
          {"b_minus_1", num(b.b_minus_1)},
          {"sigma_b", num(b.sigma_b)},
          {"calibration", {{"value", 0.0}, {"sigma_cov", num(b.calib_sigma_cov)}, {"sigma_cv", num(b.calib_sigma_cv)}}},
          {"matching",
           {{"value", num(b.matching)},
            {"sigma", num(b.matching_sigma)},
            {"db_per_px", num(b.db_dd_per_px)},
            {"rows", b.matching_rows},
            {"subpixel_floor_px", b.subpixel_floor_px}}},
          {"truth", {{"value", num(b.truth)}, {"sigma", num(b.truth_sigma)}}},
          {"notes", b.notes},
          {"sentence", b.Sentence()}};
}

std::string ScaleBudget::Sentence() const {
  if (!ok) return "Scale budget not computed: " + message + ".";
  auto pct = [](double v) { return fitting::FixedOrDash(100 * v, 2); };
  std::ostringstream o;
  o << "b - 1 = " << pct(b_minus_1) << " +- " << pct(sigma_b) << " %";
  const double calib = std::max(std::isfinite(calib_sigma_cov) ? calib_sigma_cov : 0.0,
                                std::isfinite(calib_sigma_cv) ? calib_sigma_cv : 0.0);
  const double explained2 = calib * calib + matching_sigma * matching_sigma;
  if (std::abs(b_minus_1) <= 2 * sigma_b)
    o << ": consistent with no scale error (within twice its sigma)";
  else
    o << ": " << fitting::FixedOrDash(std::abs(b_minus_1) / sigma_b, 1) << " sigma from 1";
  o << ". Calibration (f x B) allows +- " << pct(calib_sigma_cov) << " % (covariance) and +- " << pct(calib_sigma_cv)
    << " % (halves); matching moves b by " << pct(matching) << " % (second matcher) +- " << pct(matching_sigma)
    << " % (a common " << fitting::FixedOrDash(subpixel_floor_px, 2)
    << " px disparity bias); the truth's datum and scale carry the rest, " << pct(truth) << " +- " << pct(truth_sigma)
    << " %";
  if (std::abs(truth) > 2 * std::sqrt(explained2 + truth_sigma * truth_sigma))
    o << ", more than calibration and matching can explain";
  o << ".";
  return o.str();
}

}  // namespace owlcal::evaluation
