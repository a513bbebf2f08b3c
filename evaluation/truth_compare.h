#pragma once
// Every fitted number against the truth of a virtual Owl, in units and in sigma. The truth comes in
// as named values in the result's names and units (servo.*, head.* from fitting/head_fit.h
// HeadParameters in the fit's gauge; left.* / right.* intrinsics; stereo.* from StereoTruthValues)
// and fills Parameter::truth.
//
// z = (value - truth) / sigma. A parameter is "within" when |z| <= 2 (or, with sigma 0 or
// undetermined, never counted in the z statistics but listed).
#include <array>
#include <map>
#include <string>
#include <vector>

#include "fitting/result.h"
#include "models/head_model.h"

namespace owlcal::evaluation {

// Sets p.truth for every parameter whose name is in `truth` (replacing an existing truth
// only when overwrite). Returns how many were set.
int FillTruth(const std::map<std::string, double>& truth, fitting::CalibrationResult* result, bool overwrite = false);

// The intrinsics truth of a head: left.fx ... left.k3 (or up to k6), right.*.
std::map<std::string, double> IntrinsicsTruthValues(const models::HeadModel& truth);

// The stereo truth at a command: right_from_left of the two camera frames (x_right = R x_left
// + T) at `pwm_us`, as stereo.baseline_mm, stereo.tx/ty/tz (mm), stereo.rx_deg/ry_deg/rz_deg
// (rotation vector, deg), the names of fitting/stereo_fit.h. `approach`: each servo's last move
// (+1/-1/0, models::ServoMap), which side of the backlash the joints sit on.
std::map<std::string, double> StereoTruthValues(const models::HeadModel& truth,
                                                const models::PwmVector& pwm_us,
                                                const std::array<int, models::kNumServos>& approach = {});

struct TruthRow {
  std::string name, unit;
  double value = 0, sigma = 0, truth = 0;
  double error = 0;  // value - truth
  double z = 0;      // error / sigma; NaN when sigma is not positive and finite
  bool determined = true;
  bool within_2sigma = false;
};

struct TruthComparison {
  std::vector<TruthRow> rows;         // parameters with a truth, in result order
  int num_with_sigma = 0;             // rows with a finite z
  double fraction_within_2sigma = 0;  // of those
  double rms_z = 0;                   // of those (about 1 when sigmas are honest)
  std::string worst;                  // name of the largest |z|
  double worst_z = 0;
  std::vector<std::string> missing_truth;  // determined parameters without a truth
};

TruthComparison CompareWithTruth(const fitting::CalibrationResult& result);

// A lens fitted with another distortion model than the truth's is compared by projection, not
// coefficient by coefficient (coefficients of two models mean different things): for each eye
// whose fitted model (`fitted[e]`, e.g. result.cameras[e] or the head's) differs from the truth's,
// the truth is taken off every intrinsics parameter of that eye (the `prefix` names: "left.",
// "head.left.", ...), and diagnostics.lens_truth.<eye> gets the projection difference
// (evaluation/projection_diff.h: through the truth and back through the fit, over a 16 x 12 grid of
// the whole image and, separately, within 60 % of the half-diagonal) in px. Returns the eyes
// compared so.
int CompareLensByProjection(const models::HeadModel& truth,
                            const std::array<const models::CameraIntrinsics*, 2>& fitted,
                            const std::vector<std::string>& prefixes,
                            fitting::CalibrationResult* result);

}  // namespace owlcal::evaluation
