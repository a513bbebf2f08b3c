#include "fitting/settling_model.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <stdexcept>

#include "fitting/ploop_analysis.h"
#include "io/number_text.h"
#include "models/statistics.h"
#include "models/units.h"

namespace owlcal::fitting {
namespace {

std::string F(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : "n/a"; }

using models::Median;

struct SettlingSpread {
  double median = kNaN, lo = kNaN, hi = kNaN;
  int settled = 0, runs = 0;
};

// The loop model over its exposure-delay uncertainty and noise seeds.
SettlingSpread Predict(
    const LoopModel& base, double gain, double amplitude_us, const SettlingOptions& o, double delay_sd) {
  SettlingSpread s;
  std::vector<double> t;
  const double spread = std::max(o.delay_spread_s, 2 * delay_sd);
  uint64_t seed = 17;
  for (double dd : {-spread, 0.0, spread}) {
    LoopModel m = base;
    m.exposure_delay_s = std::max(0.0, base.exposure_delay_s + dd);
    for (int k = 0; k < o.noise_seeds; ++k) {
      const LoopTrial tr = SimulateLoopStep(m, gain, amplitude_us, o.frames, seed++);
      ++s.runs;
      if (tr.info.settled) {
        ++s.settled;
        t.push_back(tr.info.settling_time);
      }
    }
  }
  if (!t.empty()) {
    s.median = Median(t);
    s.lo = *std::min_element(t.begin(), t.end());
    s.hi = *std::max_element(t.begin(), t.end());
  }
  return s;
}

// The P-loop trials by (gain, amplitude).
using SettlingGroups = std::map<std::pair<double, double>, std::vector<const StepTrace*>>;

// The course's ideal P loop with d frames of delay: its 2 % settling time [s] at `gain` (NaN when
// it does not settle) and whether it is stable.
double IdealSettlingS(
    double gain, int ideal_delay_frames, const LoopModel& model, const SettlingOptions& o, bool* stable) {
  const double period = 1.0 / model.fps;
  const std::vector<GainSettling> g = SettlingVersusGain({gain}, ideal_delay_frames, model.fps, o.frames);
  *stable = g[0].stable;
  return g[0].settled ? (g[0].settling_frames + ideal_delay_frames) * period : kNaN;
}

// Agreement of a row's measured trials with the loop model's spread `p`.
std::string SettlingAgreement(const SettlingRow& r, const SettlingSpread& p, double period) {
  if (r.num_ok == 0) {
    return "no measurement";
  } else if (r.num_settled == 0 && p.settled < p.runs) {
    return p.settled == 0 ? "agrees (neither settles)"
                          : "agrees (the model too settles in only " + std::to_string(p.settled) + " of " +
                                std::to_string(p.runs) + " runs)";
  } else if (r.num_settled == 0) {
    return "measured did not settle";
  } else if (p.settled == 0) {
    return "model does not settle";
  } else if (r.measured_median_s >= p.lo - period - 1e-9 && r.measured_median_s <= p.hi + period + 1e-9) {
    return "agrees";
  } else {
    return r.measured_median_s > p.hi ? "measured slower" : "measured faster";
  }
}

// Why: the course model against the loop model, part by part, and what the measurement says.
std::string SettlingWhy(const SettlingRow& r,
                        const SettlingSpread& p,
                        const LoopModel& model,
                        int ideal_delay_frames,
                        const SettlingOptions& o) {
  const double period = 1.0 / model.fps;
  const double kcrit = CriticalGain(ideal_delay_frames);
  std::string w;
  if (!r.ideal_stable) {
    w += "The course model (d = " + std::to_string(ideal_delay_frames) + ") calls K = " + F(r.gain, 3) +
         " unstable (K_crit " + F(kcrit, 3) + ")";
    w += p.settled > 0 ? "; the loop model settles: its dead zone of " + F(model.DeadZonePx(), 2) +
                             " px stops the correction once the error is small, so a slowly growing oscillation "
                             "does not start. "
                       : " and the loop model agrees. ";
  } else if (std::isfinite(r.ideal_s) && std::isfinite(p.median)) {
    w += "Course model " + F(r.ideal_s, 3) + " s, loop model " + F(p.median, 3) + " s";
    if (std::isfinite(r.no_servo_dynamics_s))
      w += " (" + F(r.no_servo_dynamics_s, 3) + " s with an ideal servo: slew and lag change it by " +
           F(p.median - r.no_servo_dynamics_s, 3) + " s";
    if (std::isfinite(r.no_dead_zone_s))
      w += std::string(std::isfinite(r.no_servo_dynamics_s) ? "; " : " (") + F(r.no_dead_zone_s, 3) +
           " s without dead zone, PWM step and noise";
    if (std::isfinite(r.no_servo_dynamics_s) || std::isfinite(r.no_dead_zone_s)) w += ")";
    w += ". ";
    if (std::isfinite(r.no_servo_dynamics_s) && r.no_servo_dynamics_s > p.median + 0.5 * period &&
        r.gain <= MonotoneGain(ideal_delay_frames) * 1.5)
      w += "An ideal servo settles later, and that is real: below the gain without overshoot the servo's "
           "slew and lag act as extra delay, so the command runs ahead of the image and the target enters the "
           "band sooner (the course model itself: K = 0.1 settles in 22 frames with d = 3, in 15 with d = 4). ";
  }
  if (r.agreement == "measured slower" || r.agreement == "measured faster") {
    w += "The measured median (" + F(r.measured_median_s, 3) + " s) is outside the model's " + F(p.lo, 3) + "-" +
         F(p.hi, 3) + " s: " +
         (r.agreement == "measured slower"
              ? "the robot is slower than the fitted slew/lag/latency say (a larger lag near the target, "
                "backlash not taken up, or a latency longer than the latency protocol measured)."
              : "the robot settles sooner than the model (noise pushed a trial into the band early, or the "
                "latency is shorter than measured).");
  } else if (r.agreement == "measured did not settle") {
    w += "No trial settled within the band: look at the traces (limit cycle between two pulses, lost target).";
  } else if (r.agreement == "model does not settle") {
    w += "The model does not settle within " + std::to_string(o.frames) + " frames but the robot did.";
  }
  if (r.num_ok < r.num_trials) {
    const std::string n = std::to_string(r.num_trials - r.num_ok), of = std::to_string(r.num_trials);
    w += ' ';
    w += n + " of " + of + " trials did not run to the end: lost target or skipped (see the step trials table).";
  }
  return w;
}

// The curve: the loop model over a gain grid for every measured amplitude.
void AddSettlingCurve(const SettlingGroups& groups,
                      const LoopModel& model,
                      const ServoMotionFit& motion,
                      int ideal_delay_frames,
                      double deg_per_us,
                      const SettlingOptions& o,
                      SettlingStudy* st) {
  std::vector<double> amps;
  for (const auto& [key, trials] : groups)
    if (std::find(amps.begin(), amps.end(), key.second) == amps.end()) amps.push_back(key.second);
  if (amps.empty()) amps = {10.0};
  SettlingOptions co = o;
  co.noise_seeds = 1;
  for (double a : amps)
    for (double g : o.curve_gains) {
      SettlingCurvePoint c;
      c.gain = g;
      c.amplitude_deg = a;
      const SettlingSpread p = Predict(model, g, a / deg_per_us, co, motion.exposure_delay_sigma_s);
      c.median_s = p.median;
      c.lo_s = p.lo;
      c.hi_s = p.hi;
      bool stable = false;
      c.ideal_s = IdealSettlingS(g, ideal_delay_frames, model, o, &stable);
      st->curve.push_back(c);
    }
}

// The notes: the loop model's numbers and the course model's delay.
void AddSettlingNotes(const LoopModel& model,
                      const ServoMotionFit& motion,
                      int ideal_delay_frames,
                      double latency_ms,
                      double deg_per_us,
                      SettlingStudy* st) {
  const double kcrit = CriticalGain(ideal_delay_frames);
  st->notes.push_back("loop model: exposure delay " + F(1000 * model.exposure_delay_s, 1) + " ms, slew " +
                      F(model.slew_us_per_s * deg_per_us, 0) + " deg/s" +
                      (motion.slew_from_prior    ? " (a prior: the steps do not determine it)"
                       : !motion.slew_determined ? " (not determined by the steps)"
                                                 : "") +
                      ", lag " + F(1000 * model.lag_s, 1) + " ms" +
                      (motion.lag_from_prior    ? " (a prior: the steps do not determine it)"
                       : !motion.lag_determined ? " (not determined by the steps)"
                                                : "") +
                      ", dead zone " + F(model.DeadZonePx(), 2) + " px, PWM step " +
                      std::to_string(model.resolution.step_us) + " us, dead band " +
                      std::to_string(model.resolution.dead_band_us) + " us, backlash " + F(model.hysteresis_us, 1) +
                      " us, noise " + F(model.noise_px, 2) + " px");
  st->notes.push_back("course model: d = " + std::to_string(ideal_delay_frames) +
                      " frames (the latency protocol's first "
                      "motion " +
                      F(latency_ms, 1) + " ms after the command = frame d + 1), K_crit " + F(kcrit, 3));
}

}  // namespace

bool SettlingOptions::Check(std::string* why) const {
  if (frames < 5 || noise_seeds < 1 || !(delay_spread_s >= 0)) {
    if (why) *why = "SettlingOptions: need frames >= 5, noise_seeds >= 1, delay_spread_s >= 0";
    return false;
  }
  return true;
}

SettlingStudy CompareSettling(const LoopModel& model,
                              const ServoMotionFit& motion,
                              const std::vector<StepTrace>& measured,
                              int ideal_delay_frames,
                              double latency_ms,
                              double deg_per_us,
                              const SettlingOptions& o) {
  std::string why;
  if (!o.Check(&why) || !model.Check(&why)) throw std::invalid_argument(why);
  if (ideal_delay_frames < 0 || !(deg_per_us > 0))
    throw std::invalid_argument("CompareSettling: ideal_delay_frames must be >= 0 and deg_per_us > 0");
  SettlingStudy st;
  st.model = model;
  st.motion = motion;
  st.latency_ms = latency_ms;
  st.ideal_delay_frames = ideal_delay_frames;
  st.deg_per_us = deg_per_us;
  auto source = [](bool prior, bool determined) {
    return prior ? "prior" : determined ? "fitted" : "fitted, not determined";
  };
  st.slew_source = source(motion.slew_from_prior, motion.slew_determined);
  st.lag_source = source(motion.lag_from_prior, motion.lag_determined);
  const double period = 1.0 / model.fps;
  // Group the P-loop trials by (gain, amplitude).
  SettlingGroups groups;
  for (const StepTrace& s : measured)
    if (s.controller == "p-loop" && !s.simulated) groups[{s.gain, std::abs(s.amplitude_deg)}].push_back(&s);
  LoopModel ideal_servo = model;
  ideal_servo.slew_us_per_s = 1e9;
  ideal_servo.lag_s = 0;
  LoopModel no_dead_zone = model;
  no_dead_zone.resolution = models::ServoResolution{};
  no_dead_zone.tolerance_px = 1e-3;
  no_dead_zone.noise_px = 0;
  no_dead_zone.hysteresis_us = 0;
  for (const auto& [key, trials] : groups) {
    SettlingRow r;
    r.gain = key.first;
    r.amplitude_deg = key.second;
    const double amp_us = key.second / deg_per_us;
    std::vector<double> t;
    for (const StepTrace* s : trials) {
      ++r.num_trials;
      // A trial that ran to the end but did not settle is a measurement ("did not settle in the
      // trial"); a lost target or a skipped trial is not.
      if (s->status != calib::TrialStatus::kOk && s->status != calib::TrialStatus::kNotSettled) continue;
      ++r.num_ok;
      if (s->info.settled) {
        ++r.num_settled;
        t.push_back(s->info.settling_time);
      }
      r.band = s->band;
    }
    r.measured_median_s = Median(t);
    r.measured_lo_s = t.empty() ? kNaN : *std::min_element(t.begin(), t.end());
    r.measured_hi_s = t.empty() ? kNaN : *std::max_element(t.begin(), t.end());
    const SettlingSpread p = Predict(model, r.gain, amp_us, o, motion.exposure_delay_sigma_s);
    r.predicted_median_s = p.median;
    r.predicted_lo_s = p.lo;
    r.predicted_hi_s = p.hi;
    r.predicted_settled = p.settled;
    r.predicted_runs = p.runs;
    if (r.num_ok == 0) r.band = SettlingBand(model, amp_us * model.px_per_us);
    r.ideal_s = IdealSettlingS(r.gain, ideal_delay_frames, model, o, &r.ideal_stable);
    // The variants over the same exposure delays and noise seeds as the loop model: one noisy run
    // against a median compared a single draw (whether it stopped just outside the band and
    // crawled) with the spread's middle.
    r.no_servo_dynamics_s = Predict(ideal_servo, r.gain, amp_us, o, motion.exposure_delay_sigma_s).median;
    r.no_dead_zone_s = Predict(no_dead_zone, r.gain, amp_us, o, motion.exposure_delay_sigma_s).median;
    r.agreement = SettlingAgreement(r, p, period);
    r.why = SettlingWhy(r, p, model, ideal_delay_frames, o);
    st.rows.push_back(r);
  }
  AddSettlingCurve(groups, model, motion, ideal_delay_frames, deg_per_us, o, &st);
  AddSettlingNotes(model, motion, ideal_delay_frames, latency_ms, deg_per_us, &st);
  return st;
}

}  // namespace owlcal::fitting
