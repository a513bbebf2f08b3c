#include "pipeline/settling_study.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <stdexcept>
#include <tuple>

#include "fitting/loop_model.h"
#include "fitting/servo_motion_fit.h"
#include "models/units.h"
#include "protocols/dataset_tables.h"
#include "protocols/fixation.h"
#include "protocols/protocol.h"

namespace owlcal::pipeline {
namespace {
// What the loop model uses for a slew or lag the step frames do not determine
// (fitting/servo_motion_fit.h): the slow end of hobby servos' slew (docs/conventions.md#facts,
// 300-400 deg/s) and a typical response lag (the default virtual Owl's are 25-50 ms).
constexpr double kPriorSlewDegPerS = 300;
constexpr double kPriorLagS = 0.03;

}  // namespace

std::optional<fitting::SettlingStudy> StudySettling(const std::string& dataset,
                                                    const std::vector<fitting::StepTrace>& steps,
                                                    const models::RobotConfig& config,
                                                    const fitting::CalibrationResult& result,
                                                    std::optional<double> latency_ms,
                                                    int delay_frames,
                                                    double fps,
                                                    std::vector<std::string>* warnings,
                                                    const std::vector<fitting::ServoResolutionResult>& resolution) {
  auto refuse = [&](const std::string& why) -> std::optional<fitting::SettlingStudy> {
    warnings->push_back("settling model vs measurement not made: " + why);
    return std::nullopt;
  };
  // Which servo the trials stepped (one servo per step-response dataset).
  int servo = -1;
  for (const protocols::StepTrialRow& row : protocols::ReadStepTrialsCsv(dataset)) {
    const int s = protocols::ServoIndexFromName(row.servo);
    if (s < 0) continue;
    if (servo >= 0 && s != servo) return refuse("the trials step more than one servo (" + row.servo + ")");
    servo = s;
  }
  if (servo < 0) return refuse("step_trials.csv names no servo");
  const models::ServoConfig& sc = config.servos[servo];

  // One motion segment per trial: the joint at rest at the first frame, every frame's command.
  using Key = std::tuple<int, double, double, int>;
  std::map<Key, fitting::MotionSegment> segs;
  for (const protocols::StepResponseRow& row : protocols::ReadStepResponseCsv(dataset)) {
    fitting::MotionSegment& s = segs[{row.step_index, row.gain, row.amplitude_deg, row.trial}];
    if (s.name.empty())
      s.name = "gain " + std::to_string(row.gain).substr(0, 4) + ", " +
               std::to_string(int(std::lround(row.amplitude_deg))) + " deg, trial " + std::to_string(row.trial);
    fitting::MotionFrame f;
    f.t_s = row.t_s;
    f.found = row.found && row.offset_px.has_value();
    f.offset_px = f.found ? *row.offset_px : 0.0;
    f.command_us = row.pwm_us;
    s.frames.push_back(f);
  }
  std::vector<fitting::MotionSegment> segments;
  for (auto& [key, s] : segs) {
    int found = 0;
    for (const auto& f : s.frames) found += f.found;
    if (found < 5 || s.frames.size() < 2) continue;
    // The joint came to rest from the fixation pose; the loop drives it back, so the first
    // command lies on the side it was approached from.
    const int d = s.frames.front().command_us - s.frames.back().command_us;
    s.initial_approach = d > 0 ? 1 : d < 0 ? -1 : 0;
    segments.push_back(std::move(s));
  }
  if (segments.empty()) return refuse("no step trial has five frames with the target found");

  fitting::ServoMotionFitOptions mo;
  mo.fps = fps;
  if (latency_ms) {
    // The latency protocol's first motion bounds the exposure delay from above (it includes the
    // servo's own dead time); keep a frame of slack either side.
    mo.exposure_delay_max_s = std::max(mo.exposure_delay_min_s + 1.0 / fps, *latency_ms / 1000.0 + 1.0 / fps);
  }
  const std::string name = models::kServoNames[servo];
  if (const fitting::Parameter* h = result.Find("servo." + name + ".hysteresis_us"); h && std::isfinite(h->value))
    mo.hysteresis_us = std::max(0.0, h->value);
  for (const fitting::ServoResolutionResult& r : resolution)
    if (r.servo == servo && r.fit.ok && r.fit.determined) mo.resolution = r.fit.resolution;
  // deg per us of the stepped servo: the head fit's, else the robot file's.
  double deg_per_us = sc.nominal_deg_per_us;
  if (const fitting::Parameter* p = result.Find("servo." + name + ".deg_per_us");
      p && std::isfinite(p->value) && p->value > 0)
    deg_per_us = p->value;
  mo.prior_slew_us_per_s = kPriorSlewDegPerS / deg_per_us;
  mo.prior_lag_s = kPriorLagS;
  const fitting::ServoMotionFit motion = fitting::FitServoMotion(segments, mo);
  if (!motion.ok) return refuse("the servo motion fit failed: " + motion.message);

  const protocols::ClosedLoopSettings step_defaults;  // the step protocol's controller settings
  fitting::LoopModel m;
  m.fps = fps;
  m.exposure_delay_s = motion.exposure_delay_s;
  m.slew_us_per_s = motion.slew_us_per_s;
  m.lag_s = motion.lag_s;
  m.hysteresis_us = mo.hysteresis_us;
  m.resolution = mo.resolution;
  m.px_per_us = std::abs(motion.px_per_us);
  const double focal_px = protocols::NominalFocalPx(config);
  m.nominal_px_per_us = focal_px * std::tan(sc.nominal_deg_per_us * kDeg);
  m.noise_px = std::max(0.05, motion.rms_px);
  m.tolerance_px = step_defaults.tolerance_px;
  m.max_step_us = step_defaults.max_step_us;
  m.latency_frames = step_defaults.latency_frames;
  if (std::string why; !m.Check(&why)) return refuse("the fitted loop model is not valid: " + why);

  // Measured settling with the model's band (the same criterion as the prediction).
  std::vector<fitting::StepTrace> measured = steps;
  for (fitting::StepTrace& s : measured) {
    if (s.t_s.size() < 3 || s.simulated) continue;
    const double step_px = std::abs(s.amplitude_deg) / deg_per_us * m.px_per_us;
    s.band = fitting::SettlingBand(m, step_px);
    fitting::StepInfoOptions o;
    o.y_init = 0.0;
    o.y_final = 1.0;
    o.settling_band = s.band;
    try {
      s.info = fitting::ComputeStepInfo(s.t_s, s.y, o);
    } catch (const std::exception&) {
      // Already checked when the trials were read; keep the 2 % metrics.
    }
  }
  try {
    fitting::SettlingStudy st = fitting::CompareSettling(
        m, motion, measured, delay_frames, latency_ms.value_or(delay_frames * 1000.0 / fps), deg_per_us);
    st.servo = servo;
    return st;
  } catch (const std::exception& e) {
    return refuse(e.what());
  }
}

}  // namespace owlcal::pipeline
