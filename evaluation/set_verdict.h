#pragma once
// A verdict on a stereo calibration set that follows from what the set leaves UNCERTAIN, not
// from coverage thresholds (a set with 52 % of the image cells covered can be fine or useless
// depending on where and how the board was held):
//
//   1. Predicted projection uncertainty (fitting/uncertainty_map.h, mrcal's method with the
//      board poses in the state): worst-direction sigma on a 16 x 12 grid, at the judged range
//      (default infinity), at infinity and at the boards' median distance. The TRUSTED REGION
//      is where sigma at the judged range < trust_threshold_noise x the observed corner noise;
//      it must cover min_trusted_working_fraction of the WORKING REGION, the pixels within
//      `working_radius_fraction` of the half-diagonal from the centre (where a target is ranged
//      or fixated; the image corners of most real sets are extrapolation, reported but not
//      judged). The report's trusted-region figure and summary use these same numbers
//      (results.json verdict.metrics.eyes.<eye>.trusted_region).
//   2. Relative sigma of each focal length and the sigma of each principal point (same
//      covariance, board poses included).
//   3. Cross-validation: the paired views are split into two interleaved halves, each half is
//      calibrated alone, and the two are compared (evaluation/projection_diff.h: the projection
//      difference with the relative rotation taken out, in the working region; the focal
//      lengths). Corner noise predicts a difference of about twice the full set's sigma; the
//      measured ratio is reported as `covariance_scale` (how optimistic the sigmas are) and the
//      difference itself is judged against physical limits. A set too small to split, or whose
//      halves cannot be calibrated alone, is poor: nothing checks it.
//   4. Physical sanity (evaluation/stereo_sanity.h): mirrored or swapped sets, baseline vs IPD,
//      relative rotation, focal length within the lens family.
//
// Status: "unusable" when the fit failed, fewer than min_pairs paired views, or a sanity
// check finds impossible geometry (mirrored/swapped); "poor" when a parameter is undetermined
// or any limit below is exceeded, or a sanity check finds implausible geometry; else "good".
// Every reason names the number and its limit; `advice` says which views to add (fill the image
// parts that hold no corner, tilt the board when the focal length is weak, more and more varied
// views when the halves disagree).
//
// Limits. The trusted region: 10 x the corner noise at infinity. The ratio is the set's geometry
// alone; mrcal's default of 1 x suits mrcal's dense, wide-angle sets but trusts nothing of any
// real Owl set (kit2020: 3 % of the image). Measured (tests/evaluation/set_verdict_real_test.cc,
// opencv5, p90 of sigma / noise over the working region): the shared real sets 1.4-7.1 (OpenCV's
// sample 1.4-1.6, kit2020 3.3-3.8, darvill2019 2.9-7.1), their small, central, fronto-parallel
// subsets 19-126; at the real sets' 0.14 px noise 10 x is 1.4 px, 0.14 deg of gaze at f ~ 585 px,
// inside the Owl's vergence budget of 0.19 deg for 5 % at 1 m (docs/conventions.md, Facts).
// 0.5 % in f is 0.5 % in every stereo range; halves whose focal lengths differ by 2 % range 2 %
// apart; two halves each hold half the data, so the full set's own error is about half of their
// difference: 4 px apart is about 2 px, 0.2 deg, for the full set. Measured: the shared real sets
// reach at most 0.34 % / 1.5 % / 2.9 px (kit2020's halves differ by 1.3-1.5 % in f although its
// sigma_f is 0.16 %: covariance_scale about 3); their subsets at least 0.73 % in f.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "evaluation/projection_diff.h"
#include "evaluation/stereo_sanity.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "fitting/uncertainty_map.h"

namespace owlcal::evaluation {

struct SetVerdictOptions {
  RigExpectation rig = RigExpectation::Owl();
  // --rig auto: when the fit is plainly not `rig` (evaluation/stereo_sanity.h WhyNotThisRig), it is
  // judged as RigExpectation::Generic() instead, and SetVerdict::rig_note says so once.
  bool recognise_rig = false;
  int min_pairs = 3;                     // fewer paired views: unusable
  double working_radius_fraction = 0.5;  // of the half-diagonal
  // The trusted region (mrcal's valid-intrinsics region, uncertainty part): grid pixels whose
  // predicted projection uncertainty at `judged_range_m` (0 = infinity, mrcal's default: a gaze
  // direction, which is what fixation and vergence use) is below trust_threshold_noise x the
  // eye's observed corner noise (per axis). The ratio sigma / noise depends only on the set's
  // geometry (the uncertainty is linear in the noise). A non-metric target is judged at infinity.
  double judged_range_m = 0.0;
  double trust_threshold_noise = 10.0;
  double min_trusted_working_fraction = 0.9;  // of the working region's grid pixels
  double max_relative_focal_sigma = 0.005;    // sigma_f / f
  double max_principal_sigma_px = 3.0;
  double max_half_focal_diff = 0.02;  // |f_A - f_B| / f
  double max_half_diff_px = 4.0;      // p90 projection difference of the halves, working region
  int min_pairs_to_split = 6;
  int grid_cols = 16, grid_rows = 12;
  bool Check(std::string* why) const;
};

struct EyeVerdictMetrics {
  fitting::UncertaintyMap at_infinity, at_boards;
  double board_distance = 0;             // target unit
  fitting::UncertaintyMap at_range;      // at the judged range (= at_infinity when that is infinite)
  double judged_distance = 0;            // target unit; 0 = infinity
  double noise_px = 0;                   // observed corner noise per axis (the eye's fit)
  double trust_limit_px = 0;             // trust_threshold_noise x noise_px
  std::vector<bool> trusted;             // per grid pixel of at_range
  double trusted_fraction = 0;           // of the whole grid
  double trusted_working_fraction = 0;   // of the grid pixels in the working region
  double working_p90_range_px = 0;       // p90 of sigma at the judged range in the working region
  double working_p90_px = 0;             // p90 of sigma at infinity in the working region
  double working_p90_boards_px = 0;      // same at the boards' distance
  double image_fraction_within_1px = 0;  // of the grid, sigma at infinity <= 1 px
  double relative_focal_sigma = 0;       // max over fx, fy
  double principal_sigma_px = 0;         // max over cx, cy
  ProjectionDiff halves;                 // ok = false when not split
  double halves_working_p90_px = 0;      // p90 of the halves' difference in the working region
  double half_focal_diff = 0;            // relative, max over fx, fy
  double covariance_scale = 0;           // halves' difference / predicted (0 = not split)
  std::vector<int> corners_per_zone;     // 3 x 3 zones of the image, row-major
};

struct SetVerdict {
  std::string status = "unusable";   // good | poor | unusable
  std::vector<std::string> reasons;  // why not good (empty when good)
  std::vector<std::string> advice;   // which views to add
  StereoSanity sanity;
  RigExpectation rig;    // the rig the set was judged as
  std::string rig_note;  // why not the rig asked for (recognise_rig), else empty
  EyeVerdictMetrics eye[2];
  int num_pairs = 0;
  // The trusted region's definition (from the options; judged_range_m = 0 when judged at
  // infinity, a non-metric target).
  double judged_range_m = 0, trust_threshold_noise = 0, working_radius_fraction = 0;
  bool split = false;             // halves calibrated and compared
  std::string split_message;      // why not
  double half_baseline_diff = 0;  // |B_A - B_B| / B
  // Each half's calibration as a rig parameter vector (left params, right params, rotation
  // vector [rad], T [m]); empty unless split and the target is metric. Written to results.json
  // as diagnostics.cross_validation; ranging uses it (evaluation/range_images_ranging.h).
  std::vector<std::vector<double>> half_rig;
  // Parameters the verdict refuses (name -> why): an eye's fx fy cx cy when its focal length is
  // weak (sigma_f over the limit, the halves' f apart, or the lens undetermined).
  std::vector<std::pair<std::string, std::string>> refused;
  nlohmann::json ToJson() const;  // {status, reasons, advice, metrics}
};

// fit: the stereo fit of `views` (views[0] left, views[1] right, as given to FitStereo with
// `options`); length_unit_m: metres per target unit (0 if not metric).
SetVerdict JudgeStereoSet(const fitting::StereoFit& fit,
                          const std::vector<calib::View> views[2],
                          const fitting::StereoFitOptions& options,
                          double length_unit_m,
                          const SetVerdictOptions& verdict_options = {});

// results.json: result->verdict = v.ToJson() (with rig and rig_note); sanity in diagnostics
// against v.rig; each reason a warning, the rig note one too; the refused parameters marked
// determined = false (sigma NaN) with the reason as note.
void AppendVerdictToResult(const SetVerdict& v, fitting::CalibrationResult* result);

}  // namespace owlcal::evaluation
