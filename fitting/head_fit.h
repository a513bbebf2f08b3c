#pragma once
// The head problem: from views of FIXED boards seen at many servo
// poses (and optionally with the neck moved), estimate jointly with Ceres
//   - each servo's models::ServoMap params (centre_us, deg_per_us, quad_deg, cubic_deg,
//     hysteresis_us; direction fixed from the robot file; hysteresis from views approached
//     from both directions),
//   - each camera's mounting (roll, yaw, offset; fitting/head_residuals.h MountParams),
//   - both eye rotation centres in the head frame, hence head.ipd_mm,
//   - the neck map (when the neck moved), every board's base_from_target pose,
//   - optionally the intrinsics, free or with a Gaussian prior from a previous fit.
// Residuals are whitened by the corner sigma, so the covariance is in physical units.
//
// GAUGE: what the data cannot see is fixed by convention (fitting/head_gauge.h, items 1-4) and
// listed in the result as determined = false with the convention in `note`; when the neck never
// moved, every servo.Neck.* is held (not determined).
// Steps: build (fitting/head_fit_setup.cc: views, initial blocks, what the data cannot
// determine, board poses by PnP), solve (robust stage, outlier rejection, final stage), the
// observability analysis and covariance of fitting/observability.h (boards eliminated; one
// rule for every fit), outputs (fitting/head_fit_output.cc).
//
// Usage:
//   HeadFitOptions opt;  opt.corner_sigma_px = 0.15;
//   HeadFit fit = FitHead(views, robot, models::NominalHeadModel(robot) /*with intrinsics*/, opt);
//   if (fit.ok) WriteResultJson(fit.result, "head.json");
#include <array>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "fitting/head_gauge.h"
#include "fitting/observability.h"
#include "fitting/result.h"
#include "fitting/robot_file_check.h"
#include "models/head_model.h"
#include "models/rigid3.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

// HeadFitOptions::covariance_clusters: which corners may share an error in the covariance from
// the residuals (fitting/observability.h ClusterRobustCovariance).
struct CovarianceClusters {
  enum class Kind {
    kModel,      // none: the model covariance alone
    kView,       // each view is a cluster
    kPlacement,  // each board placement seen by one eye
    kCell,       // the views of one placement whose five commands fall in one cell_us cell, both eyes
  };
  Kind kind = Kind::kModel;
  double cell_us = 0;  // kCell: the cell's size [us], >= 1

  static CovarianceClusters Cell(double us) { return {Kind::kCell, us}; }
  // As results.json and --covariance-clusters write it: "" (kModel), "view", "placement", "cell:B".
  std::string Spec() const;
  // The inverse of Spec (also "model" for kModel); nullopt for anything else, "cell:B" with B < 1
  // or not a number included. The one parser of the spec (the head fit, owlcal fit-datasets).
  static std::optional<CovarianceClusters> Parse(const std::string& spec);
};

// HeadFitOptions::intrinsics_floor_carry: where the intrinsics floor's shortfall is carried.
enum class FloorCarry {
  kNone,       // the intrinsics alone
  kCentres,    // and each servo's centre_us
  kServoMaps,  // and every servo map coordinate
};
// "none", "centres", "servo_maps" (results.json, --floor-carry); ParseFloorCarry is its inverse.
std::string FloorCarryName(FloorCarry carry);
std::optional<FloorCarry> ParseFloorCarry(const std::string& name);

// The noise class of boards HeadFitOptions::noise_class_of_board does not list.
inline constexpr const char* kDefaultNoiseClass = "board";

struct HeadFitOptions {
  // A fitted IPD, servo centre or scale this far from the robot file is a warning
  // (fitting/robot_file_check.h).
  RobotFileTolerance robot_file_tolerance;
  double corner_sigma_px = 0.15;  // corner noise used to whiten [px], > 0 (with estimate_corner_sigma: the
                                  // first guess, which sets the robust loss and the outlier threshold)
  // Whiten with the noise the data shows: after the solve, each eye's corner sigma per axis is
  // measured from its residuals (sum of squares over 2N - p), multiplied by
  // measured_sigma_factor, floored at min_corner_sigma_px, and the problem solved again with it,
  // so the covariance is that of the data, not of a guess.
  bool estimate_corner_sigma = false;
  // The detector's corner bias (blur, JPEG, perspective) is nearly the same on neighbouring views
  // of one board, so more views do not average it away and the residual RMS does not show it.
  // Widening sigma for it is a choice the caller documents (owlcal calibrate: 2).
  double measured_sigma_factor = 1.0;
  double min_corner_sigma_px = 0.0;
  // Covariance from the residuals themselves (fitting/observability.h ClusterRobustCovariance):
  // the corners of one cluster may share an error; "view": each view is a cluster, "placement":
  // each board placement seen by one eye (10 clusters for the standard sweep: too few for the
  // ~80 parameters); a cell: the views of one placement whose five commands fall in the same
  // cell, both eyes together (a bias neighbouring views share counts once per cell; owlcal
  // calibrate: 100 us cells); kModel (default): the model covariance alone. The result is never
  // below the white-noise covariance at the measured sigma (the model covariance divided by
  // measured_sigma_factor^2), and it does not depend on measured_sigma_factor otherwise.
  CovarianceClusters covariance_clusters;
  // The clustered covariance times this squared: the residuals cannot show a corner bias that
  // every view shares (it moves the fit, not the residuals), so sigma is widened for it (1: none).
  double robust_sigma_factor = 1.0;
  // Noise classes: corners of different kinds of target (chessboard saddles, AprilTag quad
  // corners) have different noise. A physical board (target id before "@placement",
  // fitting/board_warp.h BoardOfTarget) listed here belongs to that class; unlisted boards to
  // kDefaultNoiseClass. Each class gets its own sigma per eye: measured from its own residuals
  // with estimate_corner_sigma, else corner_sigma_px. One fit, each corner whitened by its class.
  std::map<std::string, std::string> noise_class_of_board;
  // Boards whose corners are AprilTag quad corners (calib/apriltag_free.h), by physical board
  // (as noise_class_of_board), with the tags' black-border size [m]: after the first (robust)
  // solve each such corner is compared with where the detector puts it at that solution (the
  // intersection of straight lines through the images of its two edges, which the lens bends;
  // fitting/tag_edge_corner.h), not with its own projection. Empty: no board is treated so.
  std::map<std::string, double> tag_size_of_board;
  // Noise classes (noise_class_of_board) whitened by this many times their sigma (given or
  // measured, after measured_sigma_factor), each factor >= 1; unlisted classes: 1. A tag sheet
  // stays put through the whole sweep and every view sees the same corners from nearly the same
  // place, so their detection errors repeat from view to view and more views do not average them
  // away; the residuals' scatter does not show that (owlcal calibrate: "apriltag" 3,
  // pipeline/calibrate_pipeline.cc CalibratePipelineOptions::tag_sigma_factor).
  std::map<std::string, double> sigma_factor_of_class;
  // Floor of every servo's hysteresis sigma [us]: a frame exposed before the servo fully settled
  // looks like extra backlash on both approach sides (servo lag is not in the model); 0 = none.
  double hysteresis_sigma_floor_us = 0.0;
  // A view whose RMS corner error after the robust solve exceeds this many times the median
  // view's is dropped whole (and named in warnings); 0 = off.
  double view_outlier_factor = 5.0;
  // Fit each physical board's bow (fitting/board_warp.h) with the head; false: boards are flat.
  // A bow of a few tenths of a millimetre fitted as flat biases the focal lengths, the servo
  // scales and the IPD together (owlcal calibrate turns it on).
  bool fit_board_warp = false;
  bool fit_intrinsics = false;  // false: intrinsics held at the initial head's
  // Prior covariance of each eye's intrinsics params (fx fy cx cy dist..., physical units),
  // used when fit_intrinsics; empty = no prior (intrinsics free).
  std::optional<Eigen::MatrixXd> intrinsics_prior_covariance[2];
  // Radial coefficients (1..6) held at their initial values in an opencv8 camera (the same hold
  // as IntrinsicsFitOptions::rational_fix_radial, so the head fit refines the lens the stereo fit
  // determined); empty: all fitted.
  std::vector<int> rational_fix_radial;
  // Floor of each eye's intrinsics covariance (same units; used when fit_intrinsics; empty = none).
  // The sweep's many views of a few board placements share the detector's corner bias with the
  // views the floor came from (the stereo fit's), so they make the intrinsics no more certain
  // than that fit against it, however many they are. Where the fitted covariance C_kk falls
  // short of the floor F, the shortfall D = (F - C_kk), its negative eigenvalues dropped, is
  // added to the intrinsics' block only. Carried to the parameters correlated with them
  // (C += A D A^T, A = C_(all,k) C_kk^-1) it made the servo maps and head geometry over-wide
  // where the stereo set is small and its covariance noise-limited, not a bias floor (the
  // 6-robot Monte-Carlo test's 8 stereo views: 90 and 97 % within 1 sigma).
  std::optional<Eigen::MatrixXd> intrinsics_covariance_floor[2];
  // Where else the shortfall goes, as the fit's covariance says those parameters move with the
  // intrinsics (fitting/head_fit.cc says why): kServoMaps because a focal-length error scales
  // every angle the maps give.
  FloorCarry intrinsics_floor_carry = FloorCarry::kNone;
  // Widening of the pan zero (the head-yaw gauge, fitting/head_gauge.h item 2): the sigma of the
  // two pan maps' mean angle at the robot file's centres times this factor (>= 1; 1 = none),
  // added along the direction that shifts both pan maps by one angle (ShiftServoMapAngle), so
  // nothing else changes. Pan zero is where the eye baseline is perpendicular to the optical
  // axes: it hangs on the difference of the two eye centres' depths behind the cameras (each
  // found from a 15 mm lever seen through the whole sweep), and a detector bias that every view
  // shares moves that difference in every view alike, so no clustering of the residuals sees it.
  double pan_zero_sigma_factor = 1.0;
  // Floor of that sigma after the widening [deg] (0 = none), along the same direction; the fit
  // reports the pan zero's sigma in diagnostics.head.pan_zero.sigma_deg. owlcal calibrate's fit
  // fusing the tag sheets takes the chessboard fit's: the tags do not see the eye centres' depths
  // any better, and its pan zero moved less than 0.8 of the chessboard's sigma from it while its
  // own sigma was 0.5-0.9 of it (30 robots of the prior).
  double pan_zero_sigma_floor_deg = 0.0;
  // Floor of the sigma of the focal scale g = mean of log fx, log fy over both eyes (relative;
  // 0 = none; used when fit_intrinsics). A rotating camera sees the product of a focal length and
  // a servo scale; their split comes from what fixes the focal lengths apart from the rotation
  // (the stereo fit's board views, here through the intrinsics prior). Views that pin g in the
  // sweep itself (static tag sheets reaching the image corners) can move it by more than the
  // residuals show. Where g's variance v = a^T C a falls short of the floor^2, the shortfall is
  // added along the direction the fit's covariance moves with g:
  // C += (floor^2 - v) / v^2 (C a)(C a)^T, so the servo scales, anti-correlated with g, widen as
  // the fit says they follow it, and g's conditional covariance keeps the rest.
  double focal_scale_sigma_floor = 0.0;
  // Floor of each eye's principal point covariance (cx, cy) [px^2] (empty = none; used when
  // fit_intrinsics): the shortfall is added to that 2 x 2 block alone. Over 30 robots of the
  // prior, carried like the focal scale's to everything the covariance moves with it, it made the
  // fused fit's head geometry and servo maps over-wide (81.7 and 79.4 % within 1 sigma); carried
  // to the servos' centres only, the tilt centres (86.7-93.3 %) and the servo maps (75.3-76.0 %);
  // carried nowhere, the fused fit's tilt centres are somewhat narrow (RMS(z) 1.15-1.42).
  std::optional<Eigen::MatrixXd> principal_point_covariance_floor[2];
  bool fit_nonlinear = true;             // quad_deg and cubic_deg; false: held at 0
  bool fit_hysteresis = true;            // false: held at 0
  double huber_sigma = 3.0;              // robust loss scale in sigma units for the first solve; 0 = none
  double outlier_threshold_sigma = 5.0;  // corners with |error| > this * sigma are rejected; 0 = off
  int min_corners_per_view = 6;          // smaller views are dropped (and named in warnings)
  int max_iterations = 100;
  double rank_tolerance = kDefaultRankTolerance;  // null-space threshold (fitting/observability.h rule 4)
  int num_threads = 1;

  bool Check(std::string* why) const;
};

struct HeadOutlier {
  int frame_index = 0;
  int eye = 0;
  std::string target_id;
  int corner_id = 0;
  double error_px = 0;
};

struct HeadFit {
  bool ok = false;  // false: nothing is usable, `message` says why
  std::string message;
  CalibrationResult result;  // parameters (servo.*, head.*), head, summaries, warnings, diagnostics
  models::HeadModel head;    // the estimate (same as *result.head)
  std::map<std::string, models::Rigid3d> base_from_target;
  // Covariance of `param_names` (the flat list below, physical units of their names).
  std::vector<std::string> param_names;
  Eigen::MatrixXd covariance;
  std::vector<std::string> undetermined;  // "servo.Neck.deg_per_us: the neck never moved"
  std::vector<HeadOutlier> outliers;
  double corner_sigma_px[2] = {0, 0};           // whitening sigma used per eye [px] (given or estimated)
  double measured_corner_sigma_px[2] = {0, 0};  // per-axis sigma from the residuals (estimate_corner_sigma), else 0
  // The two above are those of kDefaultNoiseClass when it has corners, else of the first class.
  // Per noise class (HeadFitOptions::noise_class_of_board): whitening sigma used, measured sigma
  // (0 when not measured) and inlier corners, per eye.
  struct NoiseClass {
    std::array<double, 2> sigma_px{0, 0};
    std::array<double, 2> measured_sigma_px{0, 0};
    std::array<int, 2> num_corners{0, 0};
  };
  std::map<std::string, NoiseClass> noise_classes;
  // Tag corners compared with the detector's straight-edge corner (tag_size_of_board), and the
  // RMS of that correction [px].
  int num_tag_edge_corrected = 0;
  double tag_edge_offset_rms_px = 0;
  int num_views_used = 0;
  int num_corners_used = 0;
};

// Fits the head. `initial` supplies the starting servo maps, geometry and (held or initial)
// intrinsics, e.g. models::NominalHeadModel(robot) with intrinsics from a previous fit; the
// servo directions and the neck centre come from `robot`. Never throws for bad data:
// degenerate input returns ok = false or names what is not determined.
HeadFit FitHead(const std::vector<calib::View>& views,
                const models::RobotConfig& robot,
                const models::HeadModel& initial,
                const HeadFitOptions& options);

}  // namespace owlcal::fitting
