#pragma once
// Stereo calibration from a folder of image pairs, shared by
// `owlcal calibrate-images` and `owlcal range-images`: detected corners -> FitStereo ->
// result, per-view residuals, coverage, and a verdict on the set.
//
// Coverage, per eye (reported, never a pass/fail threshold): the fraction of an 8 x 6 grid of
// image cells holding a corner; the largest corner radius from the image centre as a fraction
// of the half-diagonal; board tilt per view (angle between the board normal and the optical
// axis, from the per-eye fit's board poses) and the largest angle between any two views' board
// normals (orientation spread).
//
// Verdict: evaluation/set_verdict.h (from what the set leaves uncertain: predicted projection
// uncertainty, sigma of f and c, two halves of the set calibrated alone, physical sanity),
// written to results.json as `verdict` and at the top of the Markdown.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "evaluation/set_verdict.h"
#include "fitting/lens_model_choice.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"

namespace owlcal::evaluation {

struct EyeCoverage {
  double grid_fraction = 0;        // cells with a corner / 48
  double max_radius_fraction = 0;  // largest corner radius / half-diagonal
  std::vector<int> frames;         // per view
  std::vector<double> tilt_deg;    // per view
  double max_tilt_deg = 0;
  double spread_deg = 0;  // largest angle between two views' board normals
};

struct ImageSetCalibration {
  fitting::StereoFit fit;
  fitting::CalibrationResult result;
  EyeCoverage coverage[2];
  SetVerdict set_verdict;
  bool poor = false;                 // set_verdict.status != "good"
  std::vector<std::string> verdict;  // set_verdict.reasons: empty = good
  // The lens model chosen by cross-validation (fitting/lens_model_choice.h); empty when the
  // choice was off (the configured model was fitted).
  std::optional<fitting::LensModelChoice> lens_choice;
  // The board's bow chosen by cross-validation (flat or bowed, fitting/lens_model_choice.h);
  // empty when the choice was off (options.fit_board_warp was fitted).
  std::optional<fitting::BoardWarpChoice> warp_choice;
};

// observations: as from calib::DetectImagePairs. options.length_unit: the target file's unit.
// lens.enabled: the lens model is chosen by cross-validation (options.intrinsics.model is then
// only the fallback), written to results.json (diagnostics.lens_model_choice) and used for the
// fit, the verdict's refits and everything after; off (the default here): options' model.
// warp.enabled: then the board's bow is chosen the same way (flat or bowed, with the chosen
// lens model; results.json diagnostics.board_warp_choice); off: options.fit_board_warp.
ImageSetCalibration CalibrateImageSet(
    const std::vector<calib::CornerObservation>& observations,
    const fitting::StereoFitOptions& options,
    const SetVerdictOptions& verdict_options = {},
    const fitting::LensModelChoiceOptions& lens = fitting::LensModelChoiceOptions::Off(),
    const fitting::LensModelChoiceOptions& warp = fitting::LensModelChoiceOptions::Off());

// Board tilt [deg] of each view of one eye of a fit (frame index -> tilt), from per_eye poses.
std::vector<std::pair<int, double>> ViewTilts(const fitting::StereoFit& fit, int eye);

}  // namespace owlcal::evaluation
