#pragma once
// Vergence ranging evaluation: the range to each fixated target from the calibrated head
// (servo maps, rotation centres, IPD, cameras), versus the true distance, with the 1-sigma
// predicted by propagating the calibration covariance; and the course's nominal method
// (0.113 deg/us, 65 mm, configured centres, sine rule) beside it.
//
// Geometry (models/head_kinematics.h, models/vergence.h): each eye's gaze ray starts at its
// camera centre (in the base frame, for the settled PWM and the fitted maps) and passes
// through the target's detected pixel in that eye after settling -- the residual image
// offset refines the ray beyond the 1 us quantisation of the command. Without a pixel the
// ray is the optical axis. The fix is models::ClosestPointOfRays; range = |fix - midpoint of
// the two eye rotation centres| [m].
//
// The course's method (NominalRange): theta_L = (Lx - LxC) * 0.113 deg, theta_R = -(Rx -
// RxC) * 0.113 deg (inward positive), models::SineRuleFix with IPD 65 mm; range from the
// midpoint of the eyes. Centres are the robot file's configured centres.
//
// Pulse widths: the servo maps are evaluated at the pulse each servo APPLIED (after its PWM
// step and dead band, models/servo_resolution.h) with its approach, when the fixation knows it
// (Fixation::applied_us), else at the command. A fixation whose applied pulse is uncertain
// carries applied_sigma_us, which enters sigma below.
//
// Only fixations with status ok are ranged. A fixation whose two gaze rays pass further apart
// than max_ray_gap_m + max_ray_gap_per_m * range (or do not converge in front) did not look at
// one point with both eyes: its row says "off target" and it is never reported as a range.
// Both eyes can also lock onto one wrong thing (a spot of wall texture behind the target): then
// the rays meet, but the thing's apparent size does not fit the target's known size at the
// vergence distance. When the fixation measured the target's apparent radius r_px and knows its
// radius r, each eye's size depth f_x r / r_px is compared with the vergence fix's depth in that
// camera; a mean ratio outside [1 / max_size_ratio, max_size_ratio] is "off target" too, naming
// both distances. The tolerance (1.4) is wide on purpose: a 24 mm disc at 2 m is only 3.5 px in
// radius on blurred JPEG frames. Measured per eye on the fixations that did look at the disc (full
// `owlcal calibrate`, 0.22-1.97 m): 0.94-1.14 on the default robot, 0.91-1.11 on variant A,
// rising with distance (the blurred disc's equivalent radius shrinks relative to its size), so
// 1.4 leaves a factor 1.2 above the worst; variant A's 2 m fixation, locked about 12 deg below the
// disc, reads 0.41 and is off target, as does a background spot locked onto in place of a disc
// 2 m away with the wall at 3 m (0.67).
// When the target's radius is not given (a protocol without `targets`, an older dataset), the
// fixations are checked against each other: each one's apparent size implies a radius at its
// vergence fix (r_px depth / f_x), and with at least 3 of them the median is taken as the
// target's radius for the check above (one target per evaluation, as in a vergence protocol).
// A lock onto the background implies another radius (a 2 m fixation of a shrunken 24 mm disc
// ranged at 3.05 m read 33 mm against the others' 12). With fewer than 3 a note names the
// fixations left unchecked.
//
// Uncertainty: sigma_range^2 = J C J^T + J_px S_px J_px^T + J_u S_u J_u^T, where J = d range / d params by
// central differences over the named result parameters (servo.<S>.centre_us, deg_per_us,
// quad_deg, cubic_deg, hysteresis_us; head.ipd_mm; <eye>.fx/fy/cx/cy), C their covariance
// (diagnostics["covariance"] {names, matrix} when the fit wrote one, else diagonal from the
// parameters' sigmas), and S_px the detection noise of the target pixel (pixel_sigma_px per
// axis, per eye), or the PWM quantisation when no pixel is used; J_u = d range / d pulse of each
// servo and S_u = diag(applied_sigma_us^2).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/trial_status.h"
#include "fitting/named_covariance.h"
#include "fitting/result.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::evaluation {

struct Fixation {
  int index = 0;
  calib::TrialStatus status = calib::TrialStatus::kOk;        // as the protocol recorded it
  std::string reason;                                         // why not ok
  models::PwmVector pwm_us{};                                 // settled command, wire order
  std::optional<models::PwmVector> applied_us;                // the pulse each servo applied, when known
  std::array<double, models::kNumServos> applied_sigma_us{};  // uncertainty of the pulse used [us]
  std::array<int8_t, models::kNumServos> approach{};          // sign of the last (applied) move per servo
  std::optional<Eigen::Vector2d> target_px[2];                // detected target pixel per eye, after settling
  double true_distance_m = 0;                                 // from the midpoint of the eye rotation centres
  // The target's apparent radius per eye [px] and its known radius [m], when measured: the size
  // check below.
  std::optional<double> radius_px[2];
  std::optional<double> target_radius_m;
  // The pulse widths the servo maps are evaluated at: applied_us when known, else pwm_us.
  models::PwmVector Pulses() const { return applied_us ? *applied_us : pwm_us; }
};

struct RangingOptions {
  bool use_image_offset = true;  // refine the gaze with the target's pixel (else optical axis)
  double pixel_sigma_px = 0.15;  // detection noise of the target pixel, per axis
  double pwm_sigma_us = 0.2887;  // command quantisation, 1/sqrt(12) us, when no pixel is used
  double max_ray_gap_m = 0.003;  // rays further apart than this + max_ray_gap_per_m * range: off target
  double max_ray_gap_per_m = 0.003;
  // Size check: the depth the target's apparent size gives (f * radius / radius_px) over the
  // vergence fix's depth in the same camera, mean over the eyes; outside [1 / x, x]: off target.
  double max_size_ratio = 1.4;
  bool Check(std::string* why) const;
};

// The parameters a head-model range depends on (see the header comment).
std::vector<std::string> RangingParameterNames();

struct RangeFix {
  bool ok = false;
  Eigen::Vector3d point_in_base = Eigen::Vector3d::Zero();
  double range_m = 0;  // from the midpoint of the eye rotation centres
  double gap_m = 0;    // closest distance between the two gaze rays
};

// The fix of one fixation with a head model. `pixels` overrides the fixation's pixels (for
// the Jacobian); pass nullptr to use them.
RangeFix RangeFromFixation(const models::HeadModel& head,
                           const Fixation& fixation,
                           const RangingOptions& options,
                           const Eigen::Vector2d* pixels = nullptr);

// The course's nominal method; nullopt when the rays do not converge in front.
std::optional<double> NominalRange(const models::RobotConfig& config, const models::PwmVector& pwm_us);

struct RangingRow {
  int index = 0;
  double true_m = 0;
  bool ok = false;  // ranged: status ok
  calib::TrialStatus status = calib::TrialStatus::kOk;
  std::string reason;                              // why not ranged
  double range_m = 0, error_m = 0, rel_error = 0;  // error = range - true
  double sigma_m = 0;                              // predicted 1-sigma
  double gap_m = 0;
  double size_ratio = 0;            // size depth / vergence depth; NaN: not measured
  std::optional<double> nominal_m;  // course method
  double nominal_rel_error = 0;     // NaN when no nominal fix
};

struct RangingTheoryRow {
  double distance_m = 0;
  double nominal_1us_rel = 0;       // larger relative range change of +-1 us on one eye, nominal formula
  double nominal_half_px_rel = 0;   // larger of +-0.5 px fixation error on both eyes (f from the head)
  double calibrated_sigma_rel = 0;  // predicted relative 1-sigma of the calibrated head
};

struct RangingEvaluation {
  std::vector<RangingRow> rows;  // every fixation, ranged or not
  std::vector<RangingTheoryRow> theory;
  int num_ok = 0;  // rows ranged (of rows.size())
  double rms_rel_error = 0, mean_abs_rel_error = 0, max_abs_rel_error = 0;
  double fraction_within_2sigma = 0;
  double nominal_rms_rel_error = 0;     // over rows with a nominal fix
  std::vector<std::string> propagated;  // parameter names whose covariance went into sigma
  std::vector<std::string> notes;       // one per fixation not ranged, naming it and why
};

// Evaluates every fixation. theory_distances_m: the distances of the theory curve (symmetric
// straight-ahead fixation), e.g. 0.2 .. 2.0 m.
RangingEvaluation EvaluateRanging(const models::HeadModel& head,
                                  const fitting::NamedCovariance& covariance,
                                  const models::RobotConfig& config,
                                  const std::vector<Fixation>& fixations,
                                  const RangingOptions& options,
                                  const std::vector<double>& theory_distances_m);

// A synthetic fixation of the base-frame point `target` by `head`: the pan/tilt PWM that
// centre the target (rounded to whole us, as the wire carries them), neck at its centre, and
// the target's pixels at that command. nullopt when the target cannot be fixated.
std::optional<Fixation> SyntheticFixation(const models::HeadModel& head,
                                          const Eigen::Vector3d& target_in_base,
                                          double neck_us);

}  // namespace owlcal::evaluation
