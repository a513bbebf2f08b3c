#pragma once
// What a stereo chessboard capture looks like, as numbers: the statistics that put a real Owl's
// image set and the virtual Owl's side by side (bench/sim_real_bench.cc, `owlcal image-stats`).
//
// From a folder of left*/right* pairs (calib/image_pairs.h) of a chessboard:
//   detection   boards found / images;
//   residuals   per-view corner RMS of each eye's own intrinsics fit (fitting/intrinsics_fit.h,
//               the default 5-coefficient model), the per-eye and joint RMS of the stereo fit;
//   photometry  per image (calib/chessboard_image_stats.h): noise on white and black squares,
//               edge blur sigma, white/black level, saturation, JPEG blockiness, the files' JPEG
//               quality; lens shading fitted over all white squares as
//               grey = w_image * (1 - shading * r^2 / r_corner^2) (one w per image), and again
//               with a linear light gradient per image (lens_shading_curvature);
//   board warp  mrcal's two-parameter bow (sim/scene.h SceneTarget::warp_m): the deflection of
//               the board centre towards the camera along its x and y [mm] that minimises each
//               eye's intrinsics-fit RMS (grid search within +-2.5 mm, to 0.06 mm), averaged over the eyes,
//               and the per-view RMS with it;
//   placement   per view: board tilt (angle between its normal and the optical axis), distance
//               of the board centre, share of the image the board covers;
//   eye jitter  per pair, the board pose seen by the right eye (PnP with the stereo fit's
//               intrinsics), carried into the left camera by the stereo fit's right_from_left,
//               against the left eye's own; after removing the mean over pairs, the size of the
//               difference of the board centre [mm] and of the rotation [deg]. A board that moves
//               between the two eyes' exposures (hand-held, unsynchronised cameras) or eyes that
//               move between pairs make it larger; so does the noise of each eye's pose. Also the
//               ratio of the stereo fit's per-eye RMS to the per-eye fits' RMS (1 = the two eyes
//               agree on every board pose).
// Statistics are summarised by their median (and 10th/90th percentiles where a spread
// matters). Every image that could not be read or measured is counted, never dropped silently.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/detector.h"
#include "calib/image_pairs.h"
#include "calib/observation.h"
#include "calib/target.h"

namespace owlcal::fitting {

struct Spread {
  double p10 = 0, median = 0, p90 = 0, mean = 0, stddev = 0;
  int count = 0;
};
Spread SpreadOf(std::vector<double> values);

struct CaptureStats {
  std::string name;
  int num_images = 0;
  int num_found = 0;                  // boards detected (whole board)
  int num_pairs_used = 0;             // pairs in the stereo fit
  std::vector<std::string> problems;  // unreadable images, failed fits, ...
  Spread view_rms_px;                 // per view, per-eye intrinsics fits
  double mono_rms_px[2] = {0, 0};     // per-eye intrinsics fits
  double stereo_rms_px[2] = {0, 0};   // stereo fit, per eye
  double stereo_rms_joint_px = 0;
  Spread noise_white, noise_black;  // grey levels
  Spread edge_sigma_px;
  Spread white_level, black_level;
  double saturated_fraction = 0;  // mean over images
  double lens_shading = 0;        // relative loss at the image corner
  // The same with a linear light gradient across each image besides (only the brightness's
  // curvature over each board measures it): a lamp's gradient does not read as shading.
  double lens_shading_curvature = 0;
  Spread blockiness;
  int jpeg_quality = -1;       // most common quality of the files' tables
  double warp_mm[2] = {0, 0};  // along the board's x and y (0 when not measured)
  double warped_rms_px = 0;    // per-eye fit RMS with that warp (mean of the eyes)
  Spread tilt_deg, distance_m, board_area;
  Spread jitter_mm, jitter_deg;     // per pair
  double stereo_over_mono_rms = 0;  // mean of the two eyes' stereo RMS / mono RMS

  double DetectionRate() const { return num_images ? double(num_found) / num_images : 0; }
};

// Measures a folder of pairs. square unit: the target's (metres). Throws (naming the folder)
// only when the folder cannot be listed; unreadable images are counted in `problems`.
struct CaptureStatsOptions {
  calib::DetectorOptions detector;
  bool measure_warp = true;  // ~70 intrinsics fits per eye
};

CaptureStats MeasureCapture(const std::string& name,
                            const std::string& dir,
                            const calib::ImagePairOptions& pairs,
                            const calib::TargetDefinition& target,
                            const CaptureStatsOptions& options = {});

// The board warp (kx, ky) [m] minimising one eye's intrinsics-fit RMS over `views` of a
// chessboard (grid searches of 1, 0.25 and 0.0625 mm steps); *rms_px gets that RMS.
Eigen::Vector2d FitBoardWarp(const std::vector<calib::View>& views,
                             const calib::TargetDefinition& target,
                             int width,
                             int height,
                             double* rms_px);

}  // namespace owlcal::fitting
