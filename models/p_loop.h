#pragma once
// The course's incremental proportional fixation law for one servo axis, aware of what the
// servo can do (models/servo_resolution.h). Shared by the closed loop that drives the robot
// (protocols/fixation.h) and the settling model that predicts it (fitting/settling_model.h).
//
// Each update, with e the target's image offset on this axis [px] and err_us the pulse change
// that would centre it (the nominal conversion, protocols/fixation.h OffsetToPulseError):
//   - dead zone: |e| <= DeadZonePx leaves the axis alone. The dead zone is at least the
//     configured tolerance and at least 0.6 of the smallest pulse change the servo applies (its
//     PWM step or dead band) in pixels: closer than that, no command can centre the target
//     better, and an integrating loop would cycle between two pulses for ever;
//   - state += clamp(gain * err_us, -max_step_us, max_step_us): the command as a real number;
//   - the command sent is the state snapped to the servo's PWM step grid (a pulse the servo
//     applies exactly); a command the servo would ignore (within its dead band of the pulse it
//     applies) is not sent, the state keeps integrating until it is.
// `applied` follows models::ServoResolution::Next, so the loop always knows the pulse and the
// approach the servo is at.
//
// Usage:
//   PLoopAxis axis(1545, ServoState{1545, 1});
//   PLoopSettings s;  s.gain = 0.1;  s.resolution = ServoResolution::Rounding(5, 2);
//   if (auto cmd = axis.Update(e_px, err_us, s, px_per_us)) send(*cmd);
#include <algorithm>
#include <cmath>
#include <optional>

#include "models/servo_resolution.h"

namespace owlcal::models {

struct PLoopSettings {
  double gain = 0.1;
  double tolerance_px = 1.0;
  int max_step_us = 60;
  ServoResolution resolution;

  // The dead zone for an axis whose image moves px_per_us pixels per us.
  double DeadZonePx(double px_per_us) const {
    return std::max(tolerance_px, 0.6 * resolution.MinMoveUs() * std::abs(px_per_us));
  }
};

class PLoopAxis {
 public:
  PLoopAxis(int command_us, ServoState applied) : state_us_(command_us), sent_us_(command_us), applied_(applied) {}

  // One update; the command to send, or nullopt when the axis does not move. lo_us/hi_us bound
  // the command (grid commands inside them).
  std::optional<int> Update(
      double e_px, double err_us, const PLoopSettings& s, double px_per_us, int lo_us = 0, int hi_us = 1 << 20) {
    if (std::abs(e_px) <= s.DeadZonePx(px_per_us)) return std::nullopt;
    state_us_ += std::clamp(s.gain * err_us, -double(s.max_step_us), double(s.max_step_us));
    state_us_ = std::clamp(state_us_, double(lo_us), double(hi_us));
    const int next = s.resolution.SnapInside(state_us_, lo_us, hi_us);
    if (next == sent_us_) return std::nullopt;
    const ServoState after = s.resolution.Next(applied_, next);
    if (after == applied_) return std::nullopt;  // inside the dead band: the servo would not move
    sent_us_ = next;
    applied_ = after;
    return next;
  }

  // Someone else moved the servo (e.g. the runner sent a command): restart from it.
  void Reset(int command_us, ServoState applied) {
    state_us_ = command_us;
    sent_us_ = command_us;
    applied_ = applied;
  }

  double StateUs() const { return state_us_; }
  int SentUs() const { return sent_us_; }
  const ServoState& Applied() const { return applied_; }

 private:
  double state_us_;
  int sent_us_;
  ServoState applied_;
};

}  // namespace owlcal::models
