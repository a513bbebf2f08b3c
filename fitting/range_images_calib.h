#pragma once
// Stereo calibration from a folder of image pairs (issue 7, item 1), shared by
// `owlcal calibrate-images` and `owlcal range-images`: detected corners -> FitStereo ->
// result, per-view residuals, coverage, and a verdict on the set.
//
// Coverage, per eye: the fraction of an 8 x 6 grid of image cells holding a corner; the
// largest corner radius from the image centre as a fraction of the half-diagonal; board tilt
// per view (angle between the board normal and the optical axis, from the per-eye fit's board
// poses) and the largest angle between any two views' board normals (orientation spread).
//
// Verdict (a poor set says what it cannot determine, and those parameters are marked
// determined = false with sigma NaN in the result instead of a sigma that hides it):
//   paired views < min_pairs                  -> every parameter: too few poses
//   orientation spread < min_spread_deg       -> fx fy cx cy of both eyes and stereo.tz:
//       with near-parallel boards the focal length trades against the board distance
//       (Zhang's method needs differently oriented planes)
//   grid coverage < min_grid_coverage or radius < min_radius_fraction
//                                             -> k2, k3 (and k4..k6): the board stays central,
//       the outer field's distortion is extrapolated
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"

namespace owlcal::fitting {

struct ImageSetVerdictOptions {
  int min_pairs = 6;
  double min_spread_deg = 30;  // mrcal and OpenCV advise boards tilted by 30-45 deg
  double min_grid_coverage = 0.45;
  double min_radius_fraction = 0.7;
};

struct EyeCoverage {
  double grid_fraction = 0;       // cells with a corner / 48
  double max_radius_fraction = 0; // largest corner radius / half-diagonal
  std::vector<int> frames;        // per view
  std::vector<double> tilt_deg;   // per view
  double max_tilt_deg = 0;
  double spread_deg = 0;          // largest angle between two views' board normals
};

struct ImageSetCalibration {
  StereoFit fit;
  CalibrationResult result;
  EyeCoverage coverage[2];
  bool poor = false;
  std::vector<std::string> verdict;  // what cannot be determined and why; empty = fine
};

// observations: as from calib::DetectImagePairs. length_unit: the target file's unit.
ImageSetCalibration CalibrateImageSet(const std::vector<calib::CornerObservation>& observations,
                                      const StereoFitOptions& options,
                                      const ImageSetVerdictOptions& verdict_options = {});

// Board tilt [deg] of each view of one eye of a fit (frame index -> tilt), from per_eye poses.
std::vector<std::pair<int, double>> ViewTilts(const StereoFit& fit, int eye);

}  // namespace owlcal::fitting
