#pragma once
// The head problem (issue 4, parts 3 and 4): from views of FIXED boards seen at many servo
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
// GAUGE (what the data cannot see, fixed by convention, listed in the result as
// determined = false with the convention in `note`):
//   1. Mount pitch == tilt zero: R_mount * RotX(-tilt) absorbs a mount pitch exactly into the
//      tilt angle, so the mount has no pitch parameter; tilt zero = camera's optical axis
//      level in the eye frame. (Mount yaw IS observable through pan/tilt coupling.)
//   2. Head yaw: turning the head frame about its y axis shifts both pan zeros together.
//      Fixed by right_centre.z = left_centre.z (head x axis along the eye baseline, forward
//      perpendicular to it). Pan zero = optical axis along the head's forward axis (up to
//      the mount yaw).
//   3. Base yaw == neck zero: no board observation sees the robot's body, so the neck's
//      centre_us only rotates the base frame (and all boards) and is held at the robot file's
//      centre. The neck's scale, nonlinear terms and hysteresis are fitted when it moved.
//   4. Base origin: the boards and the eye centres can translate together. With the neck
//      moved, x and z are fixed by the neck axis (base origin) and only y is free: left
//      centre y is held at its initial value. Without neck motion the whole left centre is
//      held at its initial value (the right centre, so the IPD, stays free).
//   5. The neck never moved: every servo.Neck.* is held (not determined).
// After the solve, the Jacobian (columns scaled to unit norm) is checked for a null space:
// any parameter with a large component in a null direction is reported as not determined,
// naming the parameters it is coupled with. Covariance: ceres::Covariance when the Jacobian
// has full rank, else the pseudo-inverse on the determined subspace.
//
// Usage:
//   HeadFitOptions opt;  opt.corner_sigma_px = 0.15;
//   HeadFit fit = FitHead(views, robot, models::NominalHeadModel(robot) /*with intrinsics*/, opt);
//   if (fit.ok) WriteResultJson(fit.result, "head.json");
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "fitting/result.h"
#include "models/head_model.h"
#include "models/rigid3.h"
#include "models/robot_config.h"

namespace owlcal::fitting {

struct HeadFitOptions {
  double corner_sigma_px = 0.15;       // measured corner noise (whitening) [px], > 0
  bool fit_intrinsics = false;         // false: intrinsics held at the initial head's
  // Prior covariance of each eye's intrinsics params (fx fy cx cy dist..., physical units),
  // used when fit_intrinsics; empty = no prior (intrinsics free).
  std::optional<Eigen::MatrixXd> intrinsics_prior_covariance[2];
  bool fit_nonlinear = true;           // quad_deg and cubic_deg; false: held at 0
  bool fit_hysteresis = true;          // false: held at 0
  double huber_sigma = 3.0;            // robust loss scale in sigma units for the first solve; 0 = none
  double outlier_threshold_sigma = 5.0;  // corners with |error| > this * sigma are rejected; 0 = off
  int min_corners_per_view = 6;        // smaller views are dropped (and named in warnings)
  int max_iterations = 100;
  double rank_tolerance = 1e-9;        // eigenvalue / largest of the column-scaled J^T J
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
  bool ok = false;         // false: nothing is usable, `message` says why
  std::string message;
  CalibrationResult result;  // parameters (servo.*, head.*), head, summaries, warnings, diagnostics
  models::HeadModel head;    // the estimate (same as *result.head)
  std::map<std::string, models::Rigid3d> base_from_target;
  // Covariance of `param_names` (the flat list below, physical units of their names).
  std::vector<std::string> param_names;
  Eigen::MatrixXd covariance;
  std::vector<std::string> undetermined;  // "servo.Neck.deg_per_us: the neck never moved"
  std::vector<HeadOutlier> outliers;
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

// The flat, named parameters of a head (values only): servo.<Name>.{centre_us, deg_per_us,
// quad_deg, cubic_deg, hysteresis_us}, head.ipd_mm, head.<eye>.centre_{x,y,z}_mm,
// head.<eye>.mount_{roll,yaw,pitch}_deg (ZYX Euler of cam_from_eye), head.<eye>.mount_{x,y,z}_mm,
// and with_intrinsics: head.<eye>.fx ... Used for the estimate and, on the virtual Owl, the truth.
std::vector<Parameter> HeadParameters(const models::HeadModel& head, bool with_intrinsics);

// Writes `truth` (values of HeadParameters(truth)) into the matching parameters of `result`.
// The truth must be in the fit's gauge (see CanonicalHead).
void SetHeadTruth(const models::HeadModel& truth, CalibrationResult* result);

// The same physical head in the fit's gauge (header comment, items 1-4): mount pitch folded
// into the tilt maps, head frame turned about y so the eye centres have equal z (pan maps
// shifted), neck map shifted so angle(neck_centre_us) = 0, left centre y moved to
// `left_centre_fixed.y()` (neck_moved) or the whole left centre to `left_centre_fixed`.
// Projections of boards change only by the base-frame transform, which board poses absorb.
models::HeadModel CanonicalHead(const models::HeadModel& head,
                                double neck_centre_us,
                                bool neck_moved,
                                const Eigen::Vector3d& left_centre_fixed);

// Servo params that give the angle of `params` minus delta_rad at every pulse width (exact:
// the cubic is re-expanded about the shifted centre).
std::array<double, 5> ShiftServoMapAngle(const std::array<double, 5>& params, int direction, double delta_rad);

}  // namespace owlcal::fitting
