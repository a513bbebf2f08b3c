#pragma once
// The head fit's gauge: what the board observations of fitting/head_fit.h cannot see, and the
// convention that fixes it. A parameter held by a gauge is listed in the result as
// determined = false, with the convention in its note.
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
// A truth (the virtual Owl's) is compared with a fit only after CanonicalHead puts it in the
// same gauge.
#include <array>
#include <vector>

#include <Eigen/Core>

#include "fitting/result.h"
#include "models/head_model.h"

namespace owlcal::fitting {

// Result names and units of the five servo map parameters (models/servo_map.h order):
// servo.<Name>.<param>.
inline constexpr const char* kServoParamNames[5] = {
    "centre_us", "deg_per_us", "quad_deg", "cubic_deg", "hysteresis_us"};
inline constexpr const char* kServoParamUnits[5] = {"us", "deg/us", "deg", "deg", "us"};

// The flat, named parameters of a head (values only): servo.<Name>.{centre_us, deg_per_us,
// quad_deg, cubic_deg, hysteresis_us}, head.ipd_mm, head.<eye>.centre_{x,y,z}_mm,
// head.<eye>.mount_{roll,yaw,pitch}_deg (ZYX Euler of cam_from_eye), head.<eye>.mount_{x,y,z}_mm,
// and with_intrinsics: head.<eye>.fx ... Used for the estimate and, on the virtual Owl, the truth.
std::vector<Parameter> HeadParameters(const models::HeadModel& head, bool with_intrinsics);

// Writes `truth` (values of HeadParameters(truth)) into the matching parameters of `result`.
// The truth must be in the fit's gauge (see CanonicalHead).
void SetHeadTruth(const models::HeadModel& truth, CalibrationResult* result);

// The same physical head in the fit's gauge (items 1-4 above): mount pitch folded
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
