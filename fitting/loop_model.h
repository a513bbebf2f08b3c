#pragma once
// A model of the measured fixation loop for one servo axis (the step-response protocol's loop,
// protocols/fixation.h), in pulse units [us]:
//   - the camera: frame k arrives at t_k = k / fps and shows the joint at t_k -
//     exposure_delay_s (the stream latency; the latency protocol bounds it to one frame);
//   - the controller: models::PLoopAxis with the protocol's gain, tolerance, step clamp, the
//     servo's PWM step and dead band, and latency_frames waits after every command; it converts
//     the image offset to pulses with the nominal scale (nominal_px_per_us) and its command
//     reaches the servo command_delay_s after the frame arrived;
//   - the servo: the applied pulse (models::ServoResolution) with backlash (hysteresis_us
//     times the approach) is the target of a reference that slews at slew_us_per_s, followed
//     by a first-order lag lag_s (models/slew_lag.h);
//   - the image offset of the target is -px_per_us * (joint position) plus Gaussian noise.
// A step trial starts with the joint at rest `amplitude_us` away from the pulse that centres
// the target (reached from the centre, so approached with the step's sign), and runs `frames`
// frames. y_k = 1 - offset_k / offset_0 as the protocol's traces are (fitting/step_response.h).
//
// The settling band of a trial (measured or modelled) is max(2 %, (dead zone + 2 noise) / step):
// inside the loop's dead zone no command can bring the target closer, so a 2 % band smaller
// than that is a criterion no trial on that servo can meet.
#include <cstdint>
#include <string>
#include <vector>

#include "fitting/step_response.h"
#include "models/servo_resolution.h"

namespace owlcal::fitting {

struct LoopModel {
  double fps = 30;
  double exposure_delay_s = 0.1;
  double command_delay_s = 0.001;
  double slew_us_per_s = 3400;  // 380 deg/s at 0.113 deg/us
  double lag_s = 0.025;
  double hysteresis_us = 0;
  double px_per_us = 1.15;          // true image motion per us on this axis (magnitude)
  double nominal_px_per_us = 1.15;  // the controller's conversion
  models::ServoResolution resolution;
  double noise_px = 0.1;
  // Controller.
  double tolerance_px = 1.0;
  int max_step_us = 60;
  int latency_frames = 0;

  bool Check(std::string* why) const;
  // The controller's dead zone in pixels (models::PLoopSettings::DeadZonePx).
  double DeadZonePx() const;
};

// The settling band (fraction of the step) for a step of step_px pixels.
double SettlingBand(const LoopModel& model, double step_px);

struct LoopTrial {
  std::vector<double> t_s;        // frame arrival times from the first frame
  std::vector<double> offset_px;  // measured (noisy) offsets
  std::vector<double> y;          // 1 - offset / offset_0
  std::vector<int> command_us;    // command in force when each frame arrived (relative to the target's pulse)
  StepInfo info;                  // with the band of SettlingBand
  double band = 0.02;
};

// One simulated step trial. Deterministic for a seed. Throws std::invalid_argument on a model
// that fails Check or frames < 2.
LoopTrial SimulateLoopStep(const LoopModel& model, double gain, double amplitude_us, int frames, uint64_t seed);

}  // namespace owlcal::fitting
