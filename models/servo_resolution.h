#pragma once
// What a servo makes of a commanded pulse width before it moves: the PWM generator's step and
// the servo's dead band. pigpio's default sampling makes pulse widths move in 5 us steps; the
// servo ignores a change smaller than its dead band (docs/conventions.md, Facts, the Owl user guide).
//
// Model (the virtual Owl's truth, sim/servo_dynamics.h, is the case phase = ceil(step / 2)):
//   Stepped(u)  the pulse the generator produces for a command u [us]: the multiple of step_us in
//               u's bin [phase_us + k step_us, phase_us + (k + 1) step_us - 1]. A generator that
//               rounds to the nearest multiple has phase ceil(step / 2) (DefaultPhase), one that
//               truncates has phase 0. Every bin holds exactly one multiple of the step, so a
//               command that is a multiple of the step is produced exactly, whatever the phase.
//   Next(s, u)  the servo's state after command u: a stepped pulse that differs from the pulse it
//               is applying by less than dead_band_us is ignored (dead_band_us = 1: none);
//               otherwise it applies it, approached from below (+1) or above (-1).
// The state (applied pulse, approach) is what the servo maps (models/servo_map.h) are evaluated
// at: the joint angle follows the APPLIED pulse, not the last command.
//
// Usage:
//   ServoResolution r{5, 2};                  // 5 us steps, 2 us dead band
//   ServoState s{1545, +1};
//   s = r.Next(s, 1547);                      // -> {1545, +1}: same 5 us step, nothing changes
//   s = r.Next(s, 1553);                      // -> {1555, +1}
//   int grid = r.Snap(1547);                  // -> 1545: the command a controller should send
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace owlcal::models {

struct ServoState {
  int applied_us = 0;
  int approach = 0;  // sign of the last accepted change: +1 from below, -1 from above, 0 unknown
  bool operator==(const ServoState& o) const { return applied_us == o.applied_us && approach == o.approach; }
};

struct ServoResolution {
  int step_us = 1;       // >= 1
  int dead_band_us = 1;  // >= 1; changes of the stepped pulse smaller than this are ignored
  int phase_us = 0;      // in [0, step_us): first command (mod step) of a bin

  static int DefaultPhase(int step_us) { return step_us > 1 ? ((step_us + 1) / 2) % step_us : 0; }
  // A generator that rounds to the nearest multiple of `step_us` (pigpio, the virtual Owl).
  static ServoResolution Rounding(int step_us, int dead_band_us) {
    return ServoResolution{step_us, dead_band_us, DefaultPhase(step_us)};
  }

  bool Check(std::string* why) const {
    if (step_us < 1 || step_us > 100 || dead_band_us < 1 || dead_band_us > 100 || phase_us < 0 || phase_us >= step_us) {
      if (why)
        *why = "servo resolution: step " + std::to_string(step_us) + " us, dead band " + std::to_string(dead_band_us) +
               " us, phase " + std::to_string(phase_us) + " us: need 1 <= step, dead band <= 100 and 0 <= phase < step";
      return false;
    }
    return true;
  }

  // The pulse the generator produces for command u.
  int Stepped(int u_us) const {
    if (step_us <= 1) return u_us;
    const int k = FloorDiv(u_us - phase_us, step_us);
    const int bin_start = phase_us + k * step_us;
    return bin_start + Mod(-bin_start, step_us);
  }

  // The state after command u.
  ServoState Next(const ServoState& s, int u_us) const {
    const int p = Stepped(u_us);
    if (p == s.applied_us || std::abs(p - s.applied_us) < dead_band_us) return s;
    return ServoState{p, p > s.applied_us ? 1 : -1};
  }

  // The nearest command on the step grid (a multiple of the step; ties away from zero). A
  // controller that sends only grid commands knows what the servo applies.
  int Snap(double u_us) const {
    if (step_us <= 1) return int(std::lround(u_us));
    return int(std::lround(u_us / step_us)) * step_us;
  }
  // The nearest grid command inside [lo_us, hi_us] (lo <= hi); lo or hi themselves when the
  // range holds no multiple of the step.
  int SnapInside(double u_us, int lo_us, int hi_us) const {
    int g = Snap(u_us);
    if (g < lo_us) g += step_us * ((lo_us - g + step_us - 1) / step_us);
    if (g > hi_us) g -= step_us * ((g - hi_us + step_us - 1) / step_us);
    return (g < lo_us || g > hi_us) ? std::clamp(int(std::lround(u_us)), lo_us, hi_us) : g;
  }

  // The smallest change of a grid command that the servo always applies: the step, or the dead
  // band rounded up to a whole number of steps.
  int MinMoveUs() const {
    const int s = std::max(1, step_us);
    return std::max(s, ((dead_band_us + s - 1) / s) * s);
  }

  bool operator==(const ServoResolution& o) const {
    return step_us == o.step_us && dead_band_us == o.dead_band_us && phase_us == o.phase_us;
  }

 private:
  static int FloorDiv(int a, int b) { return a >= 0 ? a / b : -((-a + b - 1) / b); }
  static int Mod(int a, int b) { return ((a % b) + b) % b; }
};

// The command offsets [us] of a fine sweep that tells steps and dead bands up to span_us / 2
// apart (fitting/servo_resolution_fit.h): 0, +1, ..., +span, span - 1, ..., 0, +1, ..., +span / 2.
// A reversal shows the dead band and the backlash; ramps over more than two bins show the step
// and where its bins start. The sweep should start after a move from below (backlash taken up).
inline std::vector<int> ResolutionSweepOffsets(int span_us) {
  std::vector<int> o;
  for (int u = 0; u <= span_us; ++u) o.push_back(u);
  for (int u = span_us - 1; u >= 0; --u) o.push_back(u);
  for (int u = 1; u <= span_us / 2; ++u) o.push_back(u);
  return o;
}

}  // namespace owlcal::models
