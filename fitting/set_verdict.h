#pragma once
// A verdict on a stereo calibration set that follows from what the set leaves UNCERTAIN, not
// from coverage thresholds (a set with 52 % of the image cells covered can be fine or useless
// depending on where and how the board was held):
//
//   1. Predicted projection uncertainty (fitting/uncertainty_map.h, mrcal's method with the
//      board poses in the state): worst-direction sigma on a 16 x 12 grid, for points at
//      infinity and at the boards' median distance. Judged over the WORKING REGION, the pixels
//      within `working_radius_fraction` of the half-diagonal from the centre (where a target is
//      ranged or fixated; the image corners of most real sets are extrapolation, reported but
//      not judged): its 90th percentile at infinity must stay within max_projection_sigma_px.
//   2. Relative sigma of each focal length and the sigma of each principal point (same
//      covariance, board poses included).
//   3. Cross-validation: the paired views are split into two interleaved halves, each half is
//      calibrated alone, and the two are compared (fitting/projection_diff.h: the projection
//      difference with the relative rotation taken out, in the working region; the focal
//      lengths). Corner noise predicts a difference of about twice the full set's sigma; the
//      measured ratio is reported as `covariance_scale` (how optimistic the sigmas are) and the
//      difference itself is judged against physical limits. A set too small to split, or whose
//      halves cannot be calibrated alone, is poor: nothing checks it.
//   4. Physical sanity (fitting/stereo_sanity.h): mirrored or swapped sets, baseline vs IPD,
//      relative rotation, focal length within the lens family.
//
// Status: "unusable" when the fit failed, fewer than min_pairs paired views, or a sanity
// check finds impossible geometry (mirrored/swapped); "poor" when a parameter is undetermined
// or any limit below is exceeded, or a sanity check finds implausible geometry; else "good".
// Every reason names the number and its limit; `advice` says which views to add (fill the image
// parts that hold no corner, tilt the board when the focal length is weak, more and more varied
// views when the halves disagree).
//
// Limits, physical: 1.25 px at f ~ 585 px is 0.12 deg of gaze (the Owl's vergence budget is 0.19
// deg for 5 % at 1 m, docs/conventions.md, Facts); 0.5 % in f is 0.5 % in every stereo range;
// halves whose focal lengths differ by 2 % range 2 % apart. Measured
// (tests/fitting/set_verdict_real_test.cc, opencv5 model): the shared real sets reach at most 0.91
// px / 0.34 % / 1.5 % (kit2020's halves differ by 1.3-1.5 % in f although its sigma_f is 0.16 %:
// covariance_scale about 4); their small, central, fronto-parallel subsets at least 1.8 px / 0.73
// %.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/projection_diff.h"
#include "fitting/uncertainty_map.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "fitting/stereo_sanity.h"

namespace owlcal::fitting {

struct SetVerdictOptions {
  RigExpectation rig = RigExpectation::Owl();
  int min_pairs = 3;                        // fewer paired views: unusable
  double working_radius_fraction = 0.5;     // of the half-diagonal
  double max_projection_sigma_px = 1.25;    // p90 over the working region, at infinity
  double max_relative_focal_sigma = 0.005;  // sigma_f / f
  double max_principal_sigma_px = 3.0;
  double max_half_focal_diff = 0.02;        // |f_A - f_B| / f
  double max_half_diff_px = 4.0;            // p90 projection difference of the halves, working region
  int min_pairs_to_split = 6;
  int grid_cols = 16, grid_rows = 12;
  bool Check(std::string* why) const;
};

struct EyeVerdictMetrics {
  UncertaintyMap at_infinity, at_boards;
  double board_distance = 0;             // target unit
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
  std::string status = "unusable";       // good | poor | unusable
  std::vector<std::string> reasons;      // why not good (empty when good)
  std::vector<std::string> advice;       // which views to add
  StereoSanity sanity;
  EyeVerdictMetrics eye[2];
  int num_pairs = 0;
  bool split = false;                    // halves calibrated and compared
  std::string split_message;             // why not
  double half_baseline_diff = 0;         // |B_A - B_B| / B
  // Each half's calibration as a rig parameter vector (left params, right params, rotation
  // vector [rad], T [m]); empty unless split and the target is metric. Written to results.json
  // as diagnostics.cross_validation; ranging uses it (fitting/range_images_ranging.h).
  std::vector<std::vector<double>> half_rig;
  // Parameters the verdict refuses (name -> why): an eye's fx fy cx cy when its focal length is
  // weak (sigma_f over the limit, the halves' f apart, or the lens undetermined).
  std::vector<std::pair<std::string, std::string>> refused;
  nlohmann::json ToJson() const;         // {status, reasons, advice, metrics}
};

// fit: the stereo fit of `views` (views[0] left, views[1] right, as given to FitStereo with
// `options`); length_unit_m: metres per target unit (0 if not metric).
SetVerdict JudgeStereoSet(const StereoFit& fit,
                          const std::vector<calib::View> views[2],
                          const StereoFitOptions& options,
                          double length_unit_m,
                          const SetVerdictOptions& verdict_options = {});

// results.json: result->verdict = v.ToJson(); sanity in diagnostics; each reason a warning;
// the refused parameters marked determined = false (sigma NaN) with the reason as note.
void AppendVerdictToResult(const SetVerdict& v, const RigExpectation& rig, CalibrationResult* result);


}  // namespace owlcal::fitting
