// Protocol validation against a robot: whether a step's pulse-width quantities and amplitudes fit
// the servos' ranges in the robot file (CheckStepForRobot, protocols/protocol.h).
#include <algorithm>
#include <cmath>
#include <string>

#include "models/head_model.h"
#include "protocols/protocol.h"

namespace owlcal::protocols {

std::string CheckStepForRobot(const Step& s, const models::RobotConfig& robot) {
  const std::string where = s.Where() + ": field '";
  auto range = [&](int servo) { return robot.servos[servo].max_us - robot.servos[servo].min_us; };
  auto at_most = [&](const char* field, int value, int servo) -> std::string {
    if (value <= range(servo)) return "";
    return where + field + "': " + std::to_string(value) + " us is more than " + models::kServoNames[servo] +
           "'s range of " + std::to_string(range(servo)) + " us in the robot file";
  };
  std::string why;
  auto first = [&](const std::string& w) {
    if (why.empty()) why = w;
  };
  auto loop = [&](const ClosedLoopSettings& l) {
    for (int servo = 0; servo < models::kNumServos; ++servo) {
      first(at_most("max_step_us", l.max_step_us, servo));
      if (2 * l.limit_margin_us >= range(servo))
        first(where + "limit_margin_us': " + std::to_string(l.limit_margin_us) + " us leaves no room in " +
              models::kServoNames[servo] + "'s range of " + std::to_string(range(servo)) + " us");
    }
  };
  if (const auto* sw = std::get_if<SweepStep>(&s.params)) first(at_most("step_us", sw->step_us, sw->servo));
  if (const auto* la = std::get_if<LatencyStep>(&s.params)) first(at_most("amplitude_us", la->amplitude_us, la->servo));
  if (const auto* li = std::get_if<LimitsStep>(&s.params))
    for (int servo : li->servos) first(at_most("coarse_us", li->coarse_us, servo));
  if (const auto* fx = std::get_if<FixateStep>(&s.params)) loop(fx->loop);
  if (const auto* sr = std::get_if<StepResponseStep>(&s.params)) loop(sr->loop);
  if (const auto* vo = std::get_if<VorStep>(&s.params)) {
    // The neck's turn at the nominal scale must fit inside its range with the margin.
    const models::ServoConfig& n = robot.servos[models::kNeck];
    double amp = vo->sines_hz.empty() ? 0 : vo->amplitude_deg;
    for (double a : vo->steps_deg) amp = std::max(amp, a);
    const double us = amp / n.nominal_deg_per_us;
    const double room = std::min(n.centre_us - n.min_us, n.max_us - n.centre_us) - vo->limit_margin_us;
    if (us > room)
      first(where + "amplitude_deg': " + std::to_string(amp) + " deg (" + std::to_string(int(std::lround(us))) +
            " us of Neck) does not fit in the " + std::to_string(int(room)) +
            " us between Neck's centre and its limits' margin in the robot file");
  }
  if (const auto* ms = std::get_if<MainSequenceStep>(&s.params)) {
    // The largest saccade at the nominal scale must fit inside the pan servo's range with the margin.
    const int servo = models::kPanServo[ms->eye];
    const models::ServoConfig& c = robot.servos[servo];
    double amp = 0;
    for (double a : ms->amplitudes_deg) amp = std::max(amp, a);
    const double us = amp / c.nominal_deg_per_us;
    if (us > range(servo) - 2 * ms->limit_margin_us)
      first(where + "amplitudes_deg': " + std::to_string(amp) + " deg (" + std::to_string(int(std::lround(us))) +
            " us of " + models::kServoNames[servo] + ") does not fit in its range of " + std::to_string(range(servo)) +
            " us with the limits' margin");
  }
  if (const auto* sa = std::get_if<SaccadeStep>(&s.params))
    for (int servo = 0; servo < models::kNumServos; ++servo)
      if (2 * sa->limit_margin_us >= range(servo))
        first(where + "limit_margin_us': " + std::to_string(sa->limit_margin_us) + " us leaves no room in " +
              models::kServoNames[servo] + "'s range of " + std::to_string(range(servo)) + " us");
  return why;
}

}  // namespace owlcal::protocols
