#pragma once
// owl-pwm.h: this Owl's servo limits, centres and PWM <-> angle maps as a header that compiles
// as C (C99 and later) and as C++, included from any number of translation units (only
// `static const` objects and `static inline` functions, no external definitions).
//   - the guide's code snippet 5 names (RyB RyT RxR RxL LyB LyT LxR LxL NeckR NeckL, the
//     centres RxC ... NeckC and the *Range values) from the measured limits and fitted centres;
//   - OwlServoMap per servo: direction, centre, slope, quadratic and cubic terms, backlash and
//     the limits (models/servo_map.h's map at the middle of the backlash band);
//   - OwlPwmToDeg (PWM -> angle) and OwlDegToPwm (angle -> PWM, rounded and clamped to the
//     limits: it never returns a pulse width outside them), OwlIpdMm.
// Throws std::runtime_error when the result has no fitted servo map.
#include <string>

#include "evaluation/limits_eval.h"
#include "fitting/result.h"
#include "models/robot_config.h"

namespace owlcal::reports {

std::string OwlPwmHeader(const fitting::CalibrationResult& result,
                         const models::RobotConfig& config,
                         const evaluation::LimitsEvaluation* limits);

}  // namespace owlcal::reports
