#pragma once
// The loop model of the stepped servo, built from what calibrate measured, against the step
// trials (fitting/settling_model.h): the slew, lag and exposure delay fitted from the trials'
// frames (fitting/servo_motion_fit.h), the latency protocol's delay, the head fit's backlash
// and the step protocol's controller settings (a slew or lag the frames do not determine is held
// at a stated prior, 300 deg/s and 30 ms, and named: SettlingStudy::slew_source, lag_source).
// Each trial's settling is re-measured with the loop model's band (fitting/loop_model.h
// SettlingBand) so that measured and predicted use the same criterion.
#include <optional>
#include <string>
#include <vector>

#include "fitting/result.h"
#include "fitting/servo_resolution_fit.h"
#include "fitting/settling_model.h"
#include "fitting/step_response.h"
#include "models/robot_config.h"

namespace owlcal::pipeline {

// `dataset`: the step_response dataset folder; `steps`: its trials as calibrate read them
// (statuses included). Returns nullopt, with the reason in *warnings, when the motion of the
// servo cannot be fitted (no usable trial) — never a model made up from defaults. `resolution`:
// the measured PWM step and dead band per servo (limits step); the stepped servo's, when
// determined, replays the commands in the motion fit and the loop model (else 1 us, none).
std::optional<fitting::SettlingStudy> StudySettling(const std::string& dataset,
                                                    const std::vector<fitting::StepTrace>& steps,
                                                    const models::RobotConfig& config,
                                                    const fitting::CalibrationResult& result,
                                                    std::optional<double> latency_ms,
                                                    int delay_frames,
                                                    double fps,
                                                    std::vector<std::string>* warnings,
                                                    const std::vector<fitting::ServoResolutionResult>& resolution = {});

}  // namespace owlcal::pipeline
