#include "robot/limits_guard.h"

#include <stdexcept>

namespace owlcal::robot {

LimitsGuard::LimitsGuard(models::RobotConfig config, LogSink log) : config_(std::move(config)), log_(std::move(log)) {
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& s = config_.servos[i];
    if (s.min_us > s.max_us) {
      throw std::invalid_argument("limits guard (" + config_.name + "): servos." + models::kServoNames[i] +
                                  ".min_us = " + std::to_string(s.min_us) + " is above max_us " +
                                  std::to_string(s.max_us));
    }
  }
}

ClampResult LimitsGuard::Clamp(const models::PwmVector& pwm_us) const {
  ClampResult r;
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& s = config_.servos[i];
    const int v = pwm_us[i];
    r.pwm_us[i] = s.Clamp(v);
    if (r.pwm_us[i] != v) {
      r.clamped[i] = true;
      r.any_clamped = true;
      r.message += std::string(r.message.empty() ? "limits guard: " : ", ") + models::kServoNames[i] + " = " +
                   std::to_string(v) + " us clamped to " + std::to_string(r.pwm_us[i]) +
                   (v > s.max_us ? " (max_us)" : " (min_us)");
    }
  }
  if (r.any_clamped) {
    num_clamped_.fetch_add(1);
    if (log_) log_(r.message);
  }
  return r;
}

bool LimitsGuard::WithinLimits(const models::PwmVector& pwm_us) const {
  for (int i = 0; i < models::kNumServos; ++i) {
    if (pwm_us[i] < config_.servos[i].min_us || pwm_us[i] > config_.servos[i].max_us) return false;
  }
  return true;
}

}  // namespace owlcal::robot
