#pragma once
// Servo limits validation: configured (robot file) versus measured range per servo, and what
// ended the measured range at each end.
//
// Measured ends come from the limits protocol (protocols/ "limits" step, dataset limits.csv):
// a servo is stepped outwards from its centre until the image stops moving although the
// command changes (a physical end-stop: the joint hit its stop) or the eye-socket rim
// intrudes into the image (a usable limit before the stop), or the configured limit is
// reached with neither (the configured limit is the binding one).
// Angles of the ends use the fitted servo map when given (approach 0).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::evaluation {

enum class LimitCause { kEndStop, kSocketRim, kConfigured, kUnknown };
const char* LimitCauseName(LimitCause c);             // "end-stop", "socket rim", "configured", "unknown"
LimitCause LimitCauseFromName(const std::string& s);  // accepts the names above and endstop|rim|none

struct LimitMeasurement {
  int servo = 0;          // models::ServoIndex
  bool high_end = false;  // false: the low-PWM end
  double measured_us = 0;
  LimitCause cause = LimitCause::kUnknown;
};

struct ServoLimits {
  int servo = 0;
  std::string name;
  int configured_min_us = 0, configured_max_us = 0, configured_centre_us = 0;
  std::optional<double> measured_min_us, measured_max_us;
  LimitCause min_cause = LimitCause::kUnknown, max_cause = LimitCause::kUnknown;
  // Angles of the ends from the fitted map [deg]; NaN without a map or a measurement.
  double configured_min_deg = 0, configured_max_deg = 0, measured_min_deg = 0, measured_max_deg = 0;
  // Safe range to configure: the measured range narrowed by margin_us + stop_error_us at each
  // measured end-stop or rim, never wider than the configured range, so that it keeps margin_us
  // from the true stop when the search is off by up to stop_error_us (the limits search finds
  // stops within 5 us, protocols/limits_search.h). Equal to configured when unmeasured.
  int recommended_min_us = 0, recommended_max_us = 0;
  // measured - configured [us] at each end (positive: the measured end is further out).
  double min_excess_us = 0, max_excess_us = 0;
};

struct LimitsEvaluation {
  std::vector<ServoLimits> servos;  // the five servos, wire order
  std::vector<std::string> notes;   // e.g. "Rx high end: end-stop 12 us inside the configured limit"
};

// Combines the configuration, the measurements (any subset) and an optional fitted head.
LimitsEvaluation EvaluateLimits(const models::RobotConfig& config,
                                const std::vector<LimitMeasurement>& measurements,
                                const models::HeadModel* head,
                                int margin_us = 10,
                                int stop_error_us = 5);

}  // namespace owlcal::evaluation
