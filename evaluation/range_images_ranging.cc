#include "evaluation/range_images_ranging.h"

#include "calib/csv.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "evaluation/stereo_depth.h"
#include "fitting/format.h"
#include "models/vergence.h"

namespace owlcal::evaluation {
void AttachHalves(const SetVerdict& v, fitting::StereoRig* rig) {
  rig->halves.clear();
  for (const auto& h : v.half_rig)
    if (static_cast<int>(h.size()) == rig->NumParams()) rig->halves.push_back(h);
  if (rig->halves.size() != 2) rig->halves.clear();
}

bool RangeOptions::Check(std::string* why) const {
  if (!(min_valid_fraction > 0 && min_valid_fraction <= 1)) {
    if (why) *why = "min_valid_fraction must be in (0, 1]";
    return false;
  }
  if (!(truth_sigma_m >= 0)) {
    if (why) *why = "truth_sigma_m = " + std::to_string(truth_sigma_m) + " must be >= 0";
    return false;
  }
  return match.Check(why);
}

std::optional<double> TriangulateDepth(const fitting::StereoRig& rig,
                                       const std::vector<double>& p,
                                       const Eigen::Vector2d& left_px,
                                       const Eigen::Vector2d& right_px,
                                       const Eigen::Vector3d& axis,
                                       double* gap_m) {
  models::CameraIntrinsics cl = rig.cameras[0], cr = rig.cameras[1];
  const size_t nl = cl.params.size(), nr = cr.params.size();
  if (p.size() != nl + nr + 6) return std::nullopt;
  std::copy(p.begin(), p.begin() + nl, cl.params.begin());
  std::copy(p.begin() + nl, p.begin() + nl + nr, cr.params.begin());
  const Eigen::Vector3d rv(p[nl + nr], p[nl + nr + 1], p[nl + nr + 2]);
  const Eigen::Vector3d t(p[nl + nr + 3], p[nl + nr + 4], p[nl + nr + 5]);
  const double angle = rv.norm();
  const Eigen::Matrix3d R =
      angle > 0 ? Eigen::AngleAxisd(angle, rv / angle).toRotationMatrix() : Eigen::Matrix3d::Identity();
  Eigen::Vector3d ray_l, ray_r;
  if (!cl.Unproject(left_px.data(), ray_l.data()) || !cr.Unproject(right_px.data(), ray_r.data())) return std::nullopt;
  // Right camera in the left frame: x_left = R^T (x_right - T).
  const Eigen::Vector3d o_r = -R.transpose() * t;
  const Eigen::Vector3d d_r = R.transpose() * ray_r;
  const auto fix = models::ClosestPointOfRays(Eigen::Vector3d::Zero(), ray_l, o_r, d_r);
  if (!fix || fix->s1 <= 0) return std::nullopt;
  if (gap_m) *gap_m = fix->gap;
  return fix->point.dot(axis);
}

RectifiedTriangulation TriangulateRectified(const fitting::StereoRig& rig,
                                            const fitting::Rectification& rect,
                                            const cv::Point2d& left_rect_px,
                                            const cv::Point2d& right_rect_px) {
  RectifiedTriangulation t;
  // Rectified pixel -> raw pixel of each eye: ray in the rectified frame, rotated back by
  // R^T, projected through the calibrated camera.
  auto to_raw = [&](const cv::Point2d& u, const cv::Matx34d& P, const cv::Matx33d& Rr, int eye, Eigen::Vector2d* raw) {
    const cv::Vec3d ray_rect((u.x - P(0, 2)) / P(0, 0), (u.y - P(1, 2)) / P(1, 1), 1.0);
    const cv::Vec3d ray = Rr.t() * ray_rect;
    double pt[3] = {ray[0], ray[1], ray[2]};
    return rig.cameras[eye].Project(pt, raw->data());
  };
  if (!to_raw(left_rect_px, rect.P1, rect.R1, 0, &t.raw_px[0]) ||
      !to_raw(right_rect_px, rect.P2, rect.R2, 1, &t.raw_px[1])) {
    t.message = "match maps outside the cameras' field";
    return t;
  }
  const cv::Vec3d ax = rect.R1.t() * cv::Vec3d(0, 0, 1);
  const Eigen::Vector3d axis(ax[0], ax[1], ax[2]);
  const std::vector<double> p0 = fitting::RigParameters(rig);
  const auto z0 = TriangulateDepth(rig, p0, t.raw_px[0], t.raw_px[1], axis, &t.ray_gap_m);
  if (!z0) {
    t.message = "rays do not meet in front of the cameras";
    return t;
  }
  t.depth_m = *z0;
  const int n = rig.NumParams();
  if (rig.covariance.rows() == n && rig.covariance.cols() == n) {
    Eigen::VectorXd J = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const double var = rig.covariance(i, i);
      if (!(var > 0)) continue;
      const double h = 0.01 * std::sqrt(var);
      std::vector<double> pp = p0, pm = p0;
      pp[i] += h;
      pm[i] -= h;
      const auto zp = TriangulateDepth(rig, pp, t.raw_px[0], t.raw_px[1], axis);
      const auto zm = TriangulateDepth(rig, pm, t.raw_px[0], t.raw_px[1], axis);
      if (zp && zm) J[i] = (*zp - *zm) / (2 * h);
    }
    t.sigma_calib_m = std::sqrt(std::max(0.0, J.dot(rig.covariance * J)));
  }
  if (rig.halves.size() == 2) {
    const auto za = TriangulateDepth(rig, rig.halves[0], t.raw_px[0], t.raw_px[1], axis);
    const auto zb = TriangulateDepth(rig, rig.halves[1], t.raw_px[0], t.raw_px[1], axis);
    if (za && zb) t.sigma_cv_m = std::abs(*za - *zb) / 2;
  }
  t.ok = true;
  return t;
}

namespace {

// Triangulates one confident-enough match and predicts its sigma (header).
void Triangulate(const fitting::StereoRig& rig,
                 const fitting::Rectification& rect,
                 const RangeOptions& options,
                 RangeMeasurement* m) {
  const RectifiedTriangulation t = TriangulateRectified(rig, rect, m->match.left_px, m->match.right_px);
  if (!t.ok) {
    m->status = "failed";
    m->message = t.message;
    return;
  }
  m->raw_px[0] = t.raw_px[0];
  m->raw_px[1] = t.raw_px[1];
  m->ray_gap_m = t.ray_gap_m;
  m->range_m = t.depth_m + options.datum_offset_m;
  m->sigma_match_m = m->match.disparity_px > 0 ? t.depth_m / m->match.disparity_px * m->match.sigma_disparity_px
                                               : std::numeric_limits<double>::infinity();
  m->sigma_cov_m = t.sigma_calib_m;
  m->sigma_cv_m = t.sigma_cv_m;
  const double cov = std::isfinite(m->sigma_cov_m) ? m->sigma_cov_m : 0.0;
  const double cvv = std::isfinite(m->sigma_cv_m) ? m->sigma_cv_m : 0.0;
  m->sigma_calib_m = std::isfinite(m->sigma_cov_m) || std::isfinite(m->sigma_cv_m)
                         ? std::max(cov, cvv)
                         : std::numeric_limits<double>::quiet_NaN();
  m->sigma_m = std::hypot(std::isfinite(m->sigma_calib_m) ? m->sigma_calib_m : 0.0, m->sigma_match_m);
  m->ok = true;
}

// The second matcher's disparity at the chosen template (RangeOptions::second_matcher), recorded
// for the scale budget; it changes no status.
void RecordSecondMatcher(const cv::Mat& dense, const SgbmOptions& sgbm, const RangeOptions& o, RangeMeasurement* m) {
  if (m->match.confidence == calib::MatchConfidence::kFailed) return;
  const double tol =
      std::max(o.match.block_tolerance_px, o.match.block_tolerance_fraction * std::abs(m->match.disparity_px));
  const RoiAgreement a = DisparityAgreement(dense, sgbm, m->match.template_roi, m->match.disparity_px, tol);
  m->second_valid_fraction = a.valid_fraction();
  if (a.valid_fraction() < o.min_valid_fraction) return;
  m->second_disparity_px = a.median_px;
  m->second_agreeing_fraction = a.agreeing_fraction;
}

}  // namespace

RangeMeasurement RangeRectifiedPair(const cv::Mat& lr,
                                    const cv::Mat& rr,
                                    const fitting::StereoRig& rig,
                                    const fitting::Rectification& rect,
                                    const RangeOptions& options) {
  RangeMeasurement m;
  m.truth_sigma_m = options.truth_sigma_m;
  // Candidates in order: the first confident match wins, else the best low-confidence one
  // (highest NCC), else the first failure's reasons.
  std::vector<cv::Rect> rois = options.candidate_rois;
  if (rois.empty()) rois.push_back(options.match.template_roi);
  std::optional<calib::StereoMatch> low, first;
  int tried = 0;
  const SgbmOptions sgbm;
  const cv::Mat dense = options.second_matcher ? SgbmDisparity16(lr, rr, sgbm) : cv::Mat();
  for (const cv::Rect& roi : rois) {
    calib::StereoMatchOptions mo = options.match;
    mo.template_roi = roi;
    const calib::StereoMatch x = calib::MatchAlongRow(lr, rr, mo);
    ++tried;
    if (!first) first = x;
    if (x.confidence == calib::MatchConfidence::kOk) {
      m.match = x;
      break;
    }
    if (x.confidence == calib::MatchConfidence::kLowConfidence && (!low || x.ncc > low->ncc)) low = x;
  }
  if (m.match.confidence != calib::MatchConfidence::kOk) m.match = low ? *low : *first;
  if (rois.size() > 1)
    m.roi_how = "candidate " + std::to_string(tried) + " of " + std::to_string(rois.size()) + " at (" +
                std::to_string(m.match.template_roi.x) + ", " + std::to_string(m.match.template_roi.y) + ")";
  if (options.second_matcher) RecordSecondMatcher(dense, sgbm, options, &m);
  m.status = calib::ToString(m.match.confidence);
  m.message = m.match.message;
  if (m.match.confidence == calib::MatchConfidence::kFailed) return m;
  Triangulate(rig, rect, options, &m);
  return m;
}

RangeMeasurement RangePair(const cv::Mat& left_raw,
                           const cv::Mat& right_raw,
                           const fitting::StereoRig& rig,
                           const fitting::Rectification& rect,
                           const RangeOptions& options) {
  cv::Mat lr, rr;
  fitting::RemapPair(rect, left_raw, right_raw, &lr, &rr);
  return RangeRectifiedPair(lr, rr, rig, rect, options);
}

std::vector<RangeTruthRow> ReadRangeTruthCsv(const std::string& path) {
  const calib::CsvTable t = calib::CsvTable::Read(path, {.trim = true});
  t.RequireColumns({"left", "right"});
  std::string dist;
  double scale = 1;
  for (const auto& [name, s] :
       {std::pair<const char*, double>{"distance_cm", 0.01}, {"distance_mm", 0.001}, {"distance_m", 1}}) {
    if (!t.HasColumn(name)) continue;
    if (!dist.empty()) throw std::runtime_error(path + ":1: two distance columns, " + dist + " and " + name);
    dist = name;
    scale = s;
  }
  const char* kRoi[] = {"roi_x", "roi_y", "roi_w", "roi_h"};
  int num_roi_columns = 0;
  for (const char* c : kRoi) num_roi_columns += t.HasColumn(c);
  if (num_roi_columns != 0 && num_roi_columns != 4)
    throw std::runtime_error(path + ":1: give all four of roi_x, roi_y, roi_w, roi_h or none");
  std::vector<RangeTruthRow> rows;
  for (size_t r = 0; r < t.NumRows(); ++r) {
    RangeTruthRow row;
    row.where = t.Where(r);
    row.left = t.Text(r, "left");
    row.right = t.Text(r, "right");
    if (row.left.empty() || row.right.empty())
      throw std::runtime_error(row.where + ": left and right must name image files");
    // A true distance is a positive length; 1 km is far beyond what a stereo head ranges. A blank
    // distance (or no distance column) is an unknown distance (NaN), not an error: the pair is
    // ranged and reported with its sigma.
    row.distance_m = !dist.empty() && !t.Text(r, dist).empty() ? t.PositiveNumber(r, dist, 1e3 / scale) * scale
                                                               : std::numeric_limits<double>::quiet_NaN();
    const bool roi_given = num_roi_columns == 4 && !(t.Text(r, "roi_x").empty() && t.Text(r, "roi_y").empty() &&
                                                     t.Text(r, "roi_w").empty() && t.Text(r, "roi_h").empty());
    if (roi_given) {
      constexpr int kMaxPx = 100000;
      const int x = t.Int(r, "roi_x", 0, kMaxPx), y = t.Int(r, "roi_y", 0, kMaxPx);  // in column order
      const int w = t.Int(r, "roi_w", 5, kMaxPx), h = t.Int(r, "roi_h", 5, kMaxPx);
      row.roi = cv::Rect(x, y, w, h);
    }
    rows.push_back(row);
  }
  return rows;
}

bool RoiInsideImage(const cv::Rect& roi, const cv::Size& size) {
  // Written without x + width, which could overflow for hostile values.
  return roi.x >= 0 && roi.y >= 0 && roi.width >= 5 && roi.height >= 5 && roi.width <= size.width &&
         roi.height <= size.height && roi.x <= size.width - roi.width && roi.y <= size.height - roi.height;
}

void CheckRangeTruthRois(const std::vector<RangeTruthRow>& rows, const cv::Size& rectified_size) {
  for (const RangeTruthRow& r : rows) {
    if (r.roi.area() == 0 || RoiInsideImage(r.roi, rectified_size)) continue;
    throw std::runtime_error(r.where + ": roi " + std::to_string(r.roi.x) + " " + std::to_string(r.roi.y) + " " +
                             std::to_string(r.roi.width) + " " + std::to_string(r.roi.height) + " is not inside the " +
                             std::to_string(rectified_size.width) + "x" + std::to_string(rectified_size.height) +
                             " rectified image (refused, not clipped)");
  }
}

RangeSummary SummariseRanges(const std::vector<RangeMeasurement>& m, double min_true_m, double max_true_m) {
  RangeSummary s;
  double sum = 0, flagged_sum = 0;
  for (const auto& r : m) {
    if (r.status == "low_confidence") ++s.num_low_confidence;
    if (r.status == "failed") ++s.num_failed;
    if (!r.has_truth()) {
      ++s.num_unknown;
      continue;
    }
    if (!(r.true_m >= min_true_m - 1e-9 && r.true_m <= max_true_m + 1e-9)) continue;
    ++s.num_rows;
    if (r.status == "low_confidence" && r.ok) {
      ++s.num_flagged_ranged;
      const double rel = std::abs(r.error_m()) / r.true_m;
      flagged_sum += rel;
      s.max_abs_rel_flagged = std::max(s.max_abs_rel_flagged, rel);
    }
    if (r.status != "ok") continue;
    ++s.num_ranged;
    const double rel = std::abs(r.error_m()) / r.true_m;
    sum += rel;
    s.max_abs_rel = std::max(s.max_abs_rel, rel);
    const double z = std::abs(r.error_m()) / r.error_sigma_m();
    s.max_abs_z = std::max(s.max_abs_z, z);
    if (z > 3) ++s.num_outside_3sigma;
  }
  s.mean_abs_rel = s.num_ranged ? sum / s.num_ranged : std::numeric_limits<double>::quiet_NaN();
  s.mean_abs_rel_flagged =
      s.num_flagged_ranged ? flagged_sum / s.num_flagged_ranged : std::numeric_limits<double>::quiet_NaN();
  return s;
}

}  // namespace owlcal::evaluation
