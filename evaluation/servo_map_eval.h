#pragma once
// Evaluations of fitted servo maps (models/servo_map.h) over a range of pulse widths, at
// approach 0 (the middle of the backlash band), angles in degrees:
//   SampleServoMap        the fitted angle, the course's nominal angle (nominal_deg_per_us at
//                         the configured centre), the 1-sigma band of the fitted angle from the
//                         result's covariance of the map's determined parameters (centre,
//                         scale, quadratic, cubic; evaluation/ranging_eval.h CovarianceFromResult,
//                         first-order propagation) and, when given, the true angle;
//   ServoMapErrorOverRange fitted minus true angle: RMS, largest |error| and mean over equally
//                         spaced samples (both maps in the same gauge, fitting/head_fit.h
//                         CanonicalHead).
#include <limits>
#include <vector>

#include "fitting/result.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::evaluation {

struct ServoMapSample {
  double pwm_us = 0;
  double angle_deg = 0;    // fitted map
  double nominal_deg = 0;  // direction * nominal_deg_per_us * (pwm_us - configured centre)
  double sigma_deg = 0;    // 1 sigma of angle_deg; 0 when no map parameter has a sigma
  double truth_deg = std::numeric_limits<double>::quiet_NaN();  // NaN without truth
};

// num_intervals + 1 samples from config.min_us to config.max_us of servo `servo` of
// *result.head (which must be set). truth may be null.
std::vector<ServoMapSample> SampleServoMap(const fitting::CalibrationResult& result,
                                           const models::ServoConfig& config,
                                           int servo,
                                           const models::HeadModel* truth,
                                           int num_intervals = 100);

struct ServoMapError {
  double rms_deg = 0;
  double max_abs_deg = 0;
  double mean_deg = 0;  // fitted - true
};

// Over [lo_us, hi_us] with num_samples >= 2 samples; each head with its own direction.
ServoMapError ServoMapErrorOverRange(const models::HeadModel& fitted,
                                     const models::HeadModel& truth,
                                     int servo,
                                     double lo_us,
                                     double hi_us,
                                     int num_samples = 201);
// The same for two parameter sets (models::ServoMap order) with one direction.
ServoMapError ServoMapErrorOverRange(
    const double* fitted, const double* truth, int direction, double lo_us, double hi_us, int num_samples = 201);

// ServoMapErrorOverRange(...).rms_deg with 201 samples.
double ServoMapRmsDeg(const double* a, const double* b, int direction, double lo_us, double hi_us);

}  // namespace owlcal::evaluation
