#include "fitting/step_response.h"

#include <cmath>
#include <limits>
#include <stdexcept>

#include "models/units.h"

namespace owlcal::fitting {
namespace {

// First time the normalised response e reaches `level`, interpolated; NaN if never.
double FirstCrossing(const std::vector<double>& t, const std::vector<double>& e, double level) {
  for (size_t k = 0; k < e.size(); ++k) {
    if (e[k] >= level) {
      if (k == 0 || e[k] == e[k - 1]) return t[k];
      return t[k - 1] + (level - e[k - 1]) / (e[k] - e[k - 1]) * (t[k] - t[k - 1]);
    }
  }
  return kNaN;
}
}  // namespace

bool StepInfoOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(settling_band > 0 && settling_band < 1))
    return fail("StepInfoOptions.settling_band = " + std::to_string(settling_band) + " must be in (0, 1)");
  if (!(rise_low >= 0 && rise_low < rise_high && rise_high <= 1))
    return fail("StepInfoOptions.rise_low/rise_high = " + std::to_string(rise_low) + "/" + std::to_string(rise_high) +
                " must satisfy 0 <= low < high <= 1");
  if (y_init && !std::isfinite(*y_init)) return fail("StepInfoOptions.y_init is not finite");
  if (y_final && !std::isfinite(*y_final)) return fail("StepInfoOptions.y_final is not finite");
  return true;
}

StepInfo ComputeStepInfo(const std::vector<double>& t, const std::vector<double>& y, const StepInfoOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  if (t.size() != y.size())
    throw std::invalid_argument("ComputeStepInfo: t has " + std::to_string(t.size()) + " samples, y has " +
                                std::to_string(y.size()));
  if (y.size() < 2) throw std::invalid_argument("ComputeStepInfo: need at least 2 samples");
  for (size_t k = 1; k < t.size(); ++k)
    if (!(t[k] > t[k - 1]))
      throw std::invalid_argument("ComputeStepInfo: t[" + std::to_string(k) + "] = " + std::to_string(t[k]) +
                                  " is not after t[k-1]");
  StepInfo s;
  s.y_init = o.y_init.value_or(y.front());
  s.y_final = o.y_final.value_or(y.back());
  const double step = s.y_final - s.y_init;
  if (step == 0.0) throw std::invalid_argument("ComputeStepInfo: y_final equals y_init (no step)");
  std::vector<double> e(y.size());
  for (size_t k = 0; k < y.size(); ++k) e[k] = (y[k] - s.y_init) / step;

  const double t_low = FirstCrossing(t, e, o.rise_low);
  const double t_high = FirstCrossing(t, e, o.rise_high);
  s.rise_time = (std::isfinite(t_low) && std::isfinite(t_high)) ? t_high - t_low : kNaN;

  // Settling: scan backwards for the last sample outside the band.
  const double band = o.settling_band * std::abs(step);
  int last_out = -1;
  for (int k = int(y.size()) - 1; k >= 0; --k) {
    if (std::abs(y[k] - s.y_final) > band) {
      last_out = k;
      break;
    }
  }
  if (last_out + 1 < int(y.size())) {
    s.settled = true;
    s.settling_index = last_out + 1;
    s.settling_time = t[s.settling_index] - t.front();
  } else {
    s.settling_time = kNaN;
  }

  size_t kmax = 0;
  double emin = e[0];
  for (size_t k = 0; k < e.size(); ++k) {
    if (e[k] > e[kmax]) kmax = k;
    emin = std::min(emin, e[k]);
  }
  s.peak = y[kmax];
  s.peak_time = t[kmax] - t.front();
  s.overshoot_pct = 100.0 * std::max(0.0, e[kmax] - 1.0);
  s.undershoot_pct = 100.0 * std::max(0.0, -emin);
  s.steady_state_error = o.reference.value_or(s.y_final) - s.y_final;
  return s;
}

double SecondOrderStep(double zeta, double wn, double t) {
  if (t <= 0) return 0.0;
  if (zeta < 1.0) {
    const double wd = wn * std::sqrt(1 - zeta * zeta);
    return 1.0 - std::exp(-zeta * wn * t) * (std::cos(wd * t) + zeta * wn / wd * std::sin(wd * t));
  }
  if (zeta == 1.0) return 1.0 - std::exp(-wn * t) * (1.0 + wn * t);
  const double r = std::sqrt(zeta * zeta - 1);
  const double s1 = -wn * (zeta - r), s2 = -wn * (zeta + r);
  return 1.0 + (s2 * std::exp(s1 * t) - s1 * std::exp(s2 * t)) / (s1 - s2);
}

double SecondOrderOvershootPct(double zeta) {
  if (zeta >= 1.0) return 0.0;
  return 100.0 * std::exp(-M_PI * zeta / std::sqrt(1 - zeta * zeta));
}

double SecondOrderPeakTime(double zeta, double wn) { return M_PI / (wn * std::sqrt(1 - zeta * zeta)); }

}  // namespace owlcal::fitting
