#include "fitting/loop_model.h"

#include <cmath>
#include <random>
#include <stdexcept>

#include "models/p_loop.h"
#include "models/slew_lag.h"

namespace owlcal::fitting {

bool LoopModel::Check(std::string* why) const {
  std::string r, rw;
  if (!(fps > 0))
    r = "fps must be > 0";
  else if (!(exposure_delay_s >= 0) || !(command_delay_s >= 0))
    r = "delays must be >= 0";
  else if (!(slew_us_per_s > 0))
    r = "slew_us_per_s must be > 0";
  else if (!(lag_s >= 0))
    r = "lag_s must be >= 0";
  else if (!(hysteresis_us >= 0))
    r = "hysteresis_us must be >= 0";
  else if (!(px_per_us > 0) || !(nominal_px_per_us > 0))
    r = "px_per_us and nominal_px_per_us must be > 0";
  else if (!(noise_px >= 0) || !(tolerance_px > 0))
    r = "noise_px must be >= 0 and tolerance_px > 0";
  else if (max_step_us < 1 || latency_frames < 0)
    r = "max_step_us must be >= 1 and latency_frames >= 0";
  else if (!resolution.Check(&rw))
    r = rw;
  if (r.empty()) return true;
  if (why) *why = "LoopModel: " + r;
  return false;
}

double LoopModel::DeadZonePx() const {
  models::PLoopSettings s;
  s.tolerance_px = tolerance_px;
  s.resolution = resolution;
  return s.DeadZonePx(nominal_px_per_us);
}

double SettlingBand(const LoopModel& m, double step_px) {
  if (!(std::abs(step_px) > 0)) return 0.02;
  return std::max(0.02, (m.DeadZonePx() + 2 * m.noise_px) / std::abs(step_px));
}

LoopTrial SimulateLoopStep(const LoopModel& m, double gain, double amplitude_us, int frames, uint64_t seed) {
  std::string why;
  if (!m.Check(&why)) throw std::invalid_argument(why);
  if (frames < 2) throw std::invalid_argument("SimulateLoopStep: frames = " + std::to_string(frames) + " must be >= 2");
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> noise(0.0, 1.0);
  const double period = 1.0 / m.fps;
  // Pulses relative to the one that centres the target (0). The joint rests at the step's
  // pulse, reached with the step's sign; its position (pulse-equivalent) includes backlash.
  const int start = int(std::lround(amplitude_us));
  const int approach0 = start >= 0 ? 1 : -1;
  auto joint_target = [&](const models::ServoState& s) { return s.applied_us - m.hysteresis_us * s.approach; };
  models::ServoState applied{start, approach0};
  models::SlewLagTrajectory joint(m.slew_us_per_s, m.lag_s, -10.0, joint_target(applied));
  // The target is centred `amplitude_us` from the joint's start: returning against the step's
  // approach, the loop must also take up the backlash (2 hysteresis_us).
  const double target_pos = -m.hysteresis_us * approach0;
  models::PLoopSettings settings;
  settings.gain = gain;
  settings.tolerance_px = m.tolerance_px;
  settings.max_step_us = m.max_step_us;
  settings.resolution = m.resolution;
  models::PLoopAxis axis(start, applied);
  LoopTrial out;
  int wait = 0;
  for (int k = 0; k < frames; ++k) {
    const double t = k * period;
    const double pos = joint.At(t - m.exposure_delay_s);
    const double e = -m.px_per_us * (pos - target_pos) + m.noise_px * noise(rng);
    out.t_s.push_back(t);
    out.offset_px.push_back(e);
    out.command_us.push_back(axis.SentUs());
    if (wait > 0) {
      --wait;
      continue;
    }
    if (axis.Update(e, e / m.nominal_px_per_us, settings, m.nominal_px_per_us, -100000, 100000)) {
      joint.Command(t + m.command_delay_s, joint_target(axis.Applied()));
      wait = m.latency_frames;
    }
  }
  const double e0 = out.offset_px.front();
  for (double e : out.offset_px) out.y.push_back(std::abs(e0) > 1e-9 ? 1.0 - e / e0 : 0.0);
  out.band = SettlingBand(m, e0);
  StepInfoOptions o;
  o.y_init = 0.0;
  o.y_final = 1.0;
  o.settling_band = out.band;
  if (std::abs(e0) > 1e-9) out.info = ComputeStepInfo(out.t_s, out.y, o);
  return out;
}

}  // namespace owlcal::fitting
