#include "fitting/ploop_analysis.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace owlcal::fitting {

std::vector<double> SimulateDelayedPLoop(double gain, int delay_frames, int num_frames) {
  if (delay_frames < 0)
    throw std::invalid_argument("SimulateDelayedPLoop: delay_frames = " + std::to_string(delay_frames) +
                                " must be >= 0");
  if (num_frames < 1) throw std::invalid_argument("SimulateDelayedPLoop: num_frames must be >= 1");
  std::vector<double> y(num_frames + 1, 0.0);
  // y(k - d) for k - d <= 0 is 0 (at rest before the step).
  for (int k = 0; k < num_frames; ++k) {
    const double delayed = (k - delay_frames) > 0 ? y[k - delay_frames] : 0.0;
    y[k + 1] = y[k] + gain * (1.0 - delayed);
    if (!std::isfinite(y[k + 1])) y[k + 1] = std::copysign(1e300, y[k + 1]);
  }
  return y;
}

double CriticalGain(int d) { return 2.0 * std::sin(M_PI / (2.0 * (2.0 * d + 1.0))); }

double MonotoneGain(int d) { return std::pow(double(d), d) / std::pow(double(d + 1), d + 1); }

std::vector<GainSettling> SettlingVersusGain(const std::vector<double>& gains,
                                             int delay_frames,
                                             double fps,
                                             int num_frames) {
  if (!(fps > 0)) throw std::invalid_argument("SettlingVersusGain: fps = " + std::to_string(fps) + " must be > 0");
  const int n = num_frames > 0 ? num_frames : 2000;
  const double kcrit = CriticalGain(delay_frames);
  std::vector<GainSettling> rows;
  for (double k : gains) {
    GainSettling r;
    r.gain = k;
    r.stable = k > 0 && k < kcrit;
    const std::vector<double> y = SimulateDelayedPLoop(k, delay_frames, n);
    std::vector<double> t(y.size());
    for (size_t i = 0; i < t.size(); ++i) t[i] = double(i);
    StepInfoOptions o;
    o.y_init = 0.0;
    o.y_final = 1.0;  // the reference: an unstable loop must not "settle" on its last sample
    const StepInfo s = ComputeStepInfo(t, y, o);
    r.settled = r.stable && s.settled;
    r.settling_frames = r.settled ? s.settling_index : -1;
    r.overshoot_pct = s.overshoot_pct;
    r.settling_time_s = r.settled ? r.settling_frames / fps : std::numeric_limits<double>::quiet_NaN();
    rows.push_back(r);
  }
  return rows;
}

std::optional<GainSettling> FastestStableGain(const std::vector<GainSettling>& rows) {
  std::optional<GainSettling> best;
  for (const GainSettling& r : rows) {
    if (!r.settled) continue;
    if (!best || r.settling_frames < best->settling_frames ||
        (r.settling_frames == best->settling_frames && r.gain < best->gain))
      best = r;
  }
  return best;
}

std::vector<double> GainGrid(double lo, double hi, double step) {
  if (!(step > 0) || hi < lo) throw std::invalid_argument("GainGrid: need step > 0 and hi >= lo");
  std::vector<double> g;
  const int n = int(std::floor((hi - lo) / step + 1e-9));
  for (int i = 0; i <= n; ++i) g.push_back(lo + i * step);
  return g;
}

double PhysicalLowerBoundS(double step_deg, double slew_deg_per_s, double latency_s, double fps) {
  if (!(slew_deg_per_s > 0) || !(fps > 0)) throw std::invalid_argument("PhysicalLowerBoundS: slew and fps must be > 0");
  return std::abs(step_deg) / slew_deg_per_s + latency_s + 1.0 / fps;
}

GainStudy MakeGainStudy(int delay_frames, double fps) {
  GainStudy g;
  g.delay_frames = delay_frames;
  g.fps = fps;
  g.simulated = SettlingVersusGain(GainGrid(0.005, 0.6, 0.005), delay_frames, fps);
  g.critical_gain = CriticalGain(delay_frames);
  g.monotone_gain = MonotoneGain(delay_frames);
  g.fastest = FastestStableGain(g.simulated);
  for (double a : {2.0, 5.0, 10.0, 15.0, 20.0}) {
    g.amplitudes_deg.push_back(a);
    g.lower_bound_fast_s.push_back(PhysicalLowerBoundS(a, 400, 0.100, fps));
    g.lower_bound_slow_s.push_back(PhysicalLowerBoundS(a, 300, 0.150, fps));
  }
  return g;
}

}  // namespace owlcal::fitting
