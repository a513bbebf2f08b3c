#include "evaluation/limits_eval.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "models/units.h"

namespace owlcal::evaluation {

const char* LimitCauseName(LimitCause c) {
  switch (c) {
    case LimitCause::kEndStop:
      return "end-stop";
    case LimitCause::kSocketRim:
      return "socket rim";
    case LimitCause::kConfigured:
      return "configured";
    default:
      return "unknown";
  }
}

LimitCause LimitCauseFromName(const std::string& s) {
  if (s == "end-stop" || s == "endstop" || s == "stop") return LimitCause::kEndStop;
  if (s == "socket rim" || s == "rim" || s == "socket_rim") return LimitCause::kSocketRim;
  if (s == "configured" || s == "none" || s == "limit") return LimitCause::kConfigured;
  return LimitCause::kUnknown;
}

LimitsEvaluation EvaluateLimits(const models::RobotConfig& config,
                                const std::vector<LimitMeasurement>& measurements,
                                const models::HeadModel* head,
                                int margin_us,
                                int stop_error_us) {
  if (margin_us < 0 || stop_error_us < 0)
    throw std::invalid_argument("EvaluateLimits: margin_us and stop_error_us must be >= 0");
  const int narrow_us = margin_us + stop_error_us;
  LimitsEvaluation ev;
  auto deg = [&](int servo, std::optional<double> us) {
    if (!head || !us) return kNaN;
    return head->ServoAngle(servo, *us) * 180.0 / M_PI;
  };
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& c = config.servos[i];
    ServoLimits s;
    s.servo = i;
    s.name = models::kServoNames[i];
    s.configured_min_us = c.min_us;
    s.configured_max_us = c.max_us;
    s.configured_centre_us = c.centre_us;
    for (const LimitMeasurement& m : measurements) {
      if (m.servo < 0 || m.servo >= models::kNumServos)
        throw std::invalid_argument("EvaluateLimits: servo index " + std::to_string(m.servo) + " out of range");
      if (m.servo != i) continue;
      if (m.high_end) {
        s.measured_max_us = m.measured_us;
        s.max_cause = m.cause;
      } else {
        s.measured_min_us = m.measured_us;
        s.min_cause = m.cause;
      }
    }
    s.configured_min_deg = deg(i, double(c.min_us));
    s.configured_max_deg = deg(i, double(c.max_us));
    s.measured_min_deg = deg(i, s.measured_min_us);
    s.measured_max_deg = deg(i, s.measured_max_us);
    s.recommended_min_us = c.min_us;
    s.recommended_max_us = c.max_us;
    s.min_excess_us = s.measured_min_us ? c.min_us - *s.measured_min_us : kNaN;
    s.max_excess_us = s.measured_max_us ? *s.measured_max_us - c.max_us : kNaN;
    const bool physical_min = s.min_cause == LimitCause::kEndStop || s.min_cause == LimitCause::kSocketRim;
    const bool physical_max = s.max_cause == LimitCause::kEndStop || s.max_cause == LimitCause::kSocketRim;
    if (s.measured_min_us && physical_min)
      s.recommended_min_us = std::max(c.min_us, int(std::ceil(*s.measured_min_us)) + narrow_us);
    if (s.measured_max_us && physical_max)
      s.recommended_max_us = std::min(c.max_us, int(std::floor(*s.measured_max_us)) - narrow_us);
    auto note = [&](const char* end, std::optional<double> us, LimitCause cause, int cfg) {
      if (!us) {
        ev.notes.push_back(s.name + " " + end + " end: not measured");
        return;
      }
      const double inside = std::abs(*us - cfg);
      if ((cause == LimitCause::kEndStop || cause == LimitCause::kSocketRim) && inside > 0.5)
        ev.notes.push_back(s.name + " " + end + " end: " + LimitCauseName(cause) + " at " +
                           std::to_string(int(std::lround(*us))) + " us, " + std::to_string(int(std::lround(inside))) +
                           " us inside the configured " + std::to_string(cfg) + " us");
    };
    note("low", s.measured_min_us, s.min_cause, c.min_us);
    note("high", s.measured_max_us, s.max_cause, c.max_us);
    if (s.recommended_min_us >= s.recommended_max_us)
      ev.notes.push_back(s.name + ": no usable range left after the " + std::to_string(margin_us) + " us margin");
    ev.servos.push_back(s);
  }
  return ev;
}

}  // namespace owlcal::evaluation
