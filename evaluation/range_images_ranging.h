#pragma once
// Ranging a target in real stereo pairs: rectify with a stereo
// calibration, match a template along the rectified row (calib/stereo_match.h), triangulate,
// and predict the range sigma from the calibration covariance and the matching sigma.
//
// Range: depth of the triangulated point along the rectified z axis (perpendicular to the
// baseline), measured from the cameras' optical centres, plus `datum_offset_m` (default 0:
// the logged distance is assumed to start at the optical centres; the true datum of the
// course's distance set is unknown, a ruler under the box).
//
// Triangulation: the rectified match is mapped back to raw (distorted) pixels in each eye;
// the two raw pixels are unprojected through the calibrated cameras and the rays' closest
// point is taken (models/vergence.h). With rows aligned this equals f B / d.
//
// Status of each row (ranges.csv's `status`): the match's confidence (calib/stereo_match.h):
// ok, low_confidence (a range is given, flagged, and left out of the error statistics) or
// failed (no range). With several candidate templates (RangeOptions::candidate_rois, e.g.
// from calib/template_roi.h) the first confident one is used, else the best low-confidence one.
//
// Predicted sigma = sqrt(sigma_calib^2 + sigma_match^2):
//   sigma_match = Z / d * sigma_d                (matching sigma of the disparity, including
//                                                 the left-right check's disagreement)
//   sigma_calib^2 = J C J^T, J = dZ/dp by central differences over every calibration
//     parameter p = [left fx fy cx cy dist.., right .., rotation vector (rad), T (m)]
//     (StereoFit's covariance layout), the raw pixels held fixed. This carries the focal
//     length, baseline, principal points and the toe-in angle (a disparity offset) with all
//     their correlations. A rig without covariance (an OpenCV file) gives sigma_calib = NaN
//     and the report says so.
//   sigma_cv = |Z_A - Z_B| / 2: the same raw pixels triangulated with the two halves of the
//     calibration set, each calibrated alone (evaluation/set_verdict.h; results.json's
//     diagnostics.cross_validation). Each half carries about sqrt(2) times the full set's
//     error, so half their difference estimates the full set's error from the data, not from
//     the covariance (which real sets show to be optimistic, 4x on kit2020). sigma_calib is the
//     larger of the two.
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/stereo_match.h"
#include "evaluation/set_verdict.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "fitting/stereo_rig.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::evaluation {

// The halves of a set verdict (SetVerdict::half_rig) attached to a rig.
void AttachHalves(const SetVerdict& verdict, fitting::StereoRig* rig);

struct RangeOptions {
  calib::StereoMatchOptions match;
  std::vector<cv::Rect> candidate_rois;  // tried in order (non-empty: overrides match.template_roi)
  double datum_offset_m = 0;             // added to the depth to compare with the logged distance
  double rectify_alpha = -1;
  // Uncertainty of the logged true distance itself (ruler reading, target held by hand,
  // datum); used only when comparing with the truth: z = error / sqrt(sigma^2 + truth^2).
  double truth_sigma_m = 0;
  // The second matcher (RangePair, RangeRectifiedPair): OpenCV's StereoSGBM (evaluation/stereo_depth.h
  // defaults: block 7, uniqueness 10 %, left-right check 1 px) over the rectified pair; its median
  // disparity at the chosen template is recorded for the scale budget (evaluation/range_scale_budget.h)
  // when at least min_valid_fraction of the template's pixels have one. It changes no status.
  bool second_matcher = true;
  double min_valid_fraction = 0.3;  // as DepthOptions::min_valid_fraction
  bool Check(std::string* why) const;
};

struct RangeMeasurement {
  std::string name;                                          // pair name (left file)
  double true_m = std::numeric_limits<double>::quiet_NaN();  // NaN: distance unknown
  calib::StereoMatch match;
  bool ok = false;                // a range was computed (status ok or low_confidence)
  std::string status = "failed";  // ok | low_confidence | failed
  std::string message;            // why not ok (the match's flags), or empty
  std::string roi_how;            // how the template was chosen
  Eigen::Vector2d raw_px[2];      // matched template centre in each raw image
  double range_m = 0;             // depth + datum offset
  double ray_gap_m = 0;           // closest distance between the two rays
  double sigma_m = 0;             // total predicted sigma
  double sigma_calib_m = 0;       // from the calibration covariance (NaN if unknown)
  double sigma_match_m = 0;       // from the matching sigma
  double sigma_cov_m = 0;         // calibration term from the covariance (NaN if unknown)
  double sigma_cv_m = 0;          // calibration term from the set's halves (NaN if unknown)
  double truth_sigma_m = 0;       // RangeOptions::truth_sigma_m
  // The second matcher at the chosen template (NaN when not cross-checked): median disparity,
  // share of its valid pixels agreeing with the match, share of the template's pixels valid.
  double second_disparity_px = std::numeric_limits<double>::quiet_NaN();
  double second_agreeing_fraction = std::numeric_limits<double>::quiet_NaN();
  double second_valid_fraction = std::numeric_limits<double>::quiet_NaN();
  double error_sigma_m() const { return std::hypot(sigma_m, truth_sigma_m); }
  double error_m() const { return range_m - true_m; }
  bool has_truth() const { return std::isfinite(true_m); }
};

// A pair of rectified pixels (same scene point in the left and right rectified images) mapped
// back to raw pixels and triangulated through the calibrated cameras; sigma_calib_m = sqrt(J C
// J^T) over the rig's covariance (see above), NaN when the rig has none; sigma_cv_m from the
// rig's two halves (see above), NaN without them.
struct RectifiedTriangulation {
  bool ok = false;
  std::string message;  // why not
  Eigen::Vector2d raw_px[2];
  double depth_m = 0;  // along the rectified z axis, from the optical centres
  double ray_gap_m = 0;
  double sigma_calib_m = std::numeric_limits<double>::quiet_NaN();
  double sigma_cv_m = std::numeric_limits<double>::quiet_NaN();
};
RectifiedTriangulation TriangulateRectified(const fitting::StereoRig& rig,
                                            const fitting::Rectification& rect,
                                            const cv::Point2d& left_rect_px,
                                            const cv::Point2d& right_rect_px);

// Ranges one raw pair. Never throws for "target not found" (ok = false, status failed, message).
RangeMeasurement RangePair(const cv::Mat& left_raw,
                           const cv::Mat& right_raw,
                           const fitting::StereoRig& rig,
                           const fitting::Rectification& rect,
                           const RangeOptions& options);
// The same on an already rectified pair (RemapPair).
RangeMeasurement RangeRectifiedPair(const cv::Mat& left_rect,
                                    const cv::Mat& right_rect,
                                    const fitting::StereoRig& rig,
                                    const fitting::Rectification& rect,
                                    const RangeOptions& options);

// Depth of the closest point of the rays through two raw pixels, along `axis` (unit, left
// camera frame) for the rig's parameters p (covariance layout). nullopt if a pixel cannot be
// unprojected or the rays are parallel.
std::optional<double> TriangulateDepth(const fitting::StereoRig& rig,
                                       const std::vector<double>& p,
                                       const Eigen::Vector2d& left_px,
                                       const Eigen::Vector2d& right_px,
                                       const Eigen::Vector3d& axis,
                                       double* gap_m = nullptr);

// Truth file: CSV with header (calib/csv.h); columns left, right (file names relative to the
// CSV's folder or the image folder) and at most one of distance_cm | distance_mm | distance_m (a
// positive finite length up to 1 km). A blank distance, or no distance column at all, means
// "unknown" (NaN): the pair is ranged and reported with its sigma, with no error. Optional
// roi_x, roi_y, roi_w, roi_h (all four or none; integers, x, y >= 0, w, h >= 5: the template in
// the left rectified image; a row may leave all four empty to use the default). Throws naming
// file, line and column.
struct RangeTruthRow {
  std::string where;  // "path:line" of the row, for messages
  std::string left, right;
  double distance_m = 0;
  cv::Rect roi;  // empty = options' default
};
std::vector<RangeTruthRow> ReadRangeTruthCsv(const std::string& path);
// True if `roi` is a template (w, h >= 5) wholly inside an image of `size`.
bool RoiInsideImage(const cv::Rect& roi, const cv::Size& size);
// Refuses (throws std::runtime_error naming the row's path:line) a row ROI that is not inside the
// rectified image: an ROI is never clipped or moved to fit.
void CheckRangeTruthRois(const std::vector<RangeTruthRow>& rows, const cv::Size& rectified_size);

struct RangeSummary {
  int num_rows = 0, num_ranged = 0;  // rows with a truth in range; of them status ok
  int num_low_confidence = 0, num_failed = 0, num_unknown = 0;
  double mean_abs_rel = 0;  // over ranged rows with truth
  double max_abs_rel = 0;
  double max_abs_z = 0;  // max |error| / sigma
  int num_outside_3sigma = 0;
  // The low-confidence rows that have a range and a truth in range (the classifier's flagged
  // group, to compare with the confident rows'): their count and |error| / truth.
  int num_flagged_ranged = 0;
  double mean_abs_rel_flagged = 0, max_abs_rel_flagged = 0;
};
RangeSummary SummariseRanges(const std::vector<RangeMeasurement>& m, double min_true_m = 0, double max_true_m = 1e9);

}  // namespace owlcal::evaluation
