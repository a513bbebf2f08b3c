#pragma once
// Client- and server-side safety: clamps every outgoing servo command to one robot's limits
// (robot file, models::RobotConfig), and reports which servos were clamped.
//
// Each value is clamped to [min_us, max_us] of its servo (wire order Rx Ry Lx Ly Neck).
// A clamp is reported through an optional log sink (never written to std::cerr directly),
// e.g. "limits guard: Rx = 2100 us clamped to 1890 (max_us)".
//
// Usage:
//   LimitsGuard guard(models::DefaultRobotConfig(),
//                     [](const std::string& line) { std::cerr << line << "\n"; });
//   ClampResult c = guard.Clamp({2100, 1530, 1545, 1580, 1530});
//   // c.pwm_us[kRx] == 1890, c.clamped[kRx] == true, c.any_clamped == true
#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>

#include "models/robot_config.h"

namespace owlcal::robot {

using LogSink = std::function<void(const std::string&)>;

struct ClampResult {
  models::PwmVector pwm_us{};                      // the value after clamping
  std::array<bool, models::kNumServos> clamped{};  // per servo: value was changed
  bool any_clamped = false;
  std::string message;  // "" or one line naming every clamp
};

class LimitsGuard {
 public:
  // Throws std::invalid_argument if a servo's min_us > max_us.
  explicit LimitsGuard(models::RobotConfig config, LogSink log = nullptr);

  // Clamps every value to its servo's [min_us, max_us]; logs the clamp if any. Thread-safe
  // (the config is immutable; the counter is atomic).
  ClampResult Clamp(const models::PwmVector& pwm_us) const;

  // True if every value already lies within the limits.
  bool WithinLimits(const models::PwmVector& pwm_us) const;

  const models::RobotConfig& Config() const { return config_; }
  // Number of Clamp() calls that changed at least one value.
  int64_t NumClamped() const { return num_clamped_.load(); }

 private:
  models::RobotConfig config_;
  LogSink log_;
  mutable std::atomic<int64_t> num_clamped_{0};
};

}  // namespace owlcal::robot
