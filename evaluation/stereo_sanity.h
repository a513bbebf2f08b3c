#pragma once
// Physical sanity checks of a stereo result (OpenCV's R, T: x_right = R x_left + T) against
// the rig it claims to be: a wrong input gives a fit with a fine RMS and impossible geometry,
// and this says so, naming the flag that fixes it.
//
// Checks (severity in brackets; `unusable` means the geometry cannot be right):
//   T_x sign [unusable]: the right camera sits on the +x side of the left one, so T_x < 0.
//     T_x > 0 is what a MIRRORED set (halves cut from the Owl's stream without the flip:
//     --mirror) or a SWAPPED set (left and right exchanged: --swap) gives. A chessboard cannot
//     tell the two apart (a mirrored planar board is the same board seen rotated), so both
//     flags are named, with how to tell which.
//   T direction [poor]: |(T_y, T_z)| / |T| above max_off_axis_fraction: the cameras are not side
//     by side (or R, T are garbage).
//   baseline vs IPD [poor] (rig with an IPD, metric units only): | |T| - IPD | above the
//     tolerance; a ratio near a round factor hints at the target file's square size.
//   relative rotation [poor]: angle of R above max_rotation_deg (toe-in, a loose camera, or a
//     wrong pairing of images).
//   focal length [poor] (rig with a lens family): fx, fy of each eye outside the family's
//     range scaled to the image width; |fx/fy - 1| above max_aspect_error (square pixels);
//     the two eyes' f differing by more than max_focal_mismatch.
//   principal point [poor]: farther than max_principal_offset_fraction * width from the
//     image centre.
//
// The Owl (RigExpectation::Owl(), docs/conventions.md, Facts): OV5647 with a 3.6 mm lens at 640x480, spec
// 635 px, real Owls measured 578-591 px -> family 540-680 px at 640 px; design IPD 65 mm,
// calibrated baselines 62.5-64.9 mm -> 65 +- 8 mm. RigExpectation::Generic(): any side-by-side
// stereo pair (no IPD, no lens family), e.g. OpenCV's sample set.
#include <string>
#include <vector>

#include "fitting/result.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::evaluation {

struct RigExpectation {
  std::string name = "owl";
  double ipd_m = 0.065;  // 0 = no IPD check
  double ipd_tolerance_m = 0.008;
  double focal_min_px = 540, focal_max_px = 680;  // at reference_width_px; 0 = no lens family
  double reference_width_px = 640;
  double max_aspect_error = 0.02;
  double max_focal_mismatch = 0.05;  // |f_left / f_right - 1|
  double max_rotation_deg = 10;
  double max_off_axis_fraction = 0.3;
  double max_principal_offset_fraction = 0.15;

  static RigExpectation Owl();
  static RigExpectation Generic();
  bool Check(std::string* why) const;
};

struct SanityFinding {
  std::string check;      // "tx_sign", "t_direction", "baseline", "rotation", "focal", "principal_point"
  bool unusable = false;  // else poor
  std::string message;    // what is wrong, why it matters, what fixes it
};

struct StereoSanity {
  std::vector<SanityFinding> findings;
  bool mirrored_or_swapped = false;
  bool ok() const { return findings.empty(); }
};

// cameras[0] left, [1] right; right_from_left's translation in the fit's length unit;
// length_unit_m: metres per unit (0 when the unit is not metric, e.g. "square": the baseline
// check is skipped).
StereoSanity CheckStereoSanity(const models::CameraIntrinsics cameras[2],
                               const models::Rigid3d& right_from_left,
                               double length_unit_m,
                               const RigExpectation& expect);

// Why a fit is plainly not `expect` (one clause per sign, e.g. "baseline 99.8 mm, not the owl
// rig's 65.0 +- 8.0 mm; left eye f = 533.6 px, outside the owl lens family (540-680 px)"), or
// empty when it could be. Plainly not = BOTH signs a target file cannot fake: the baseline outside
// the IPD tolerance (metric units, a rig with an IPD) and either eye's fx outside the lens family;
// one sign alone is more likely a wrong square size or a set that does not pin f down, which the
// checks above report against the rig. Empty when the rig has no IPD or no lens family.
std::string WhyNotThisRig(const models::CameraIntrinsics cameras[2],
                          const models::Rigid3d& right_from_left,
                          double length_unit_m,
                          const RigExpectation& expect);

// Adds the findings to result->diagnostics["sanity"] ({rig, ok, findings: [{check, severity,
// message}]}) and each message to result->warnings.
void AppendSanityToResult(const StereoSanity& sanity, const RigExpectation& expect, fitting::CalibrationResult* result);

}  // namespace owlcal::evaluation
