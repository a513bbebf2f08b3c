#include "fitting/vor_analysis.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

#include "models/units.h"

namespace owlcal::fitting {
namespace {

double Wrap(double a) {  // to (-pi, pi]
  a = std::fmod(a + M_PI, 2 * M_PI);
  if (a <= 0) a += 2 * M_PI;
  return a - M_PI;
}

struct MeanVar {
  int n = 0;
  double mean = 0, var = 0;
};
MeanVar Window(const std::vector<double>& t, const std::vector<double>& y, double a, double b) {
  MeanVar m;
  double s = 0, s2 = 0;
  for (size_t i = 0; i < t.size(); ++i)
    if (t[i] >= a && t[i] < b && std::isfinite(y[i])) {
      s += y[i];
      s2 += y[i] * y[i];
      ++m.n;
    }
  if (m.n == 0) return m;
  m.mean = s / m.n;
  m.var = m.n > 1 ? std::max(0.0, (s2 - m.n * m.mean * m.mean) / (m.n - 1)) : 0;
  return m;
}

}  // namespace

SineFit FitSine(const std::vector<double>& t, const std::vector<double>& y, double hz) {
  SineFit f;
  const int n = int(std::min(t.size(), y.size()));
  f.num_samples = n;
  if (t.size() != y.size()) {
    f.reason = "times and values differ in length";
    return f;
  }
  if (!(hz > 0)) {
    f.reason = "frequency must be > 0";
    return f;
  }
  if (n < 6) {
    f.reason = std::to_string(n) + " samples (at least 6)";
    return f;
  }
  const auto [lo, hi] = std::minmax_element(t.begin(), t.end());
  if ((*hi - *lo) * hz < 0.5) {
    f.reason = "the samples span less than half a period";
    return f;
  }
  // y = c0 + c1 t + a sin(w t) + b cos(w t)  =>  amplitude hypot(a, b), phase atan2(b, a).
  const double w = 2 * M_PI * hz;
  Eigen::MatrixXd A(n, 4);
  Eigen::VectorXd Y(n);
  for (int i = 0; i < n; ++i) {
    A(i, 0) = 1;
    A(i, 1) = t[i];
    A(i, 2) = std::sin(w * t[i]);
    A(i, 3) = std::cos(w * t[i]);
    Y(i) = y[i];
  }
  const Eigen::Matrix4d AtA = A.transpose() * A;
  Eigen::FullPivLU<Eigen::Matrix4d> lu(AtA);
  if (lu.rank() < 4) {
    f.reason = "the samples do not determine a sine (rank " + std::to_string(lu.rank()) + ")";
    return f;
  }
  const Eigen::Vector4d c = lu.solve(A.transpose() * Y);
  const Eigen::VectorXd r = Y - A * c;
  const double s2 = r.squaredNorm() / std::max(1, n - 4);
  const Eigen::Matrix4d cov = s2 * lu.inverse();
  f.offset = c[0];
  f.drift_per_s = c[1];
  const double a = c[2], b = c[3];
  f.amplitude = std::hypot(a, b);
  f.phase_rad = std::atan2(b, a);
  f.rms_residual = std::sqrt(r.squaredNorm() / n);
  // First-order propagation through hypot and atan2.
  if (f.amplitude > 0) {
    const Eigen::Vector2d dA(a / f.amplitude, b / f.amplitude);
    const Eigen::Vector2d dP(-b / (f.amplitude * f.amplitude), a / (f.amplitude * f.amplitude));
    const Eigen::Matrix2d C = cov.block<2, 2>(2, 2);
    f.amplitude_sigma = std::sqrt(std::max(0.0, dA.dot(C * dA)));
    f.phase_sigma_rad = std::sqrt(std::max(0.0, dP.dot(C * dP)));
  }
  f.ok = true;
  return f;
}

VorGain GainFromSines(const SineFit& neck, const SineFit& pan, double hz) {
  VorGain g;
  if (!neck.ok || !pan.ok) {
    g.reason = !neck.ok ? "neck sine not fitted: " + neck.reason : "eye sine not fitted: " + pan.reason;
    return g;
  }
  if (!(neck.amplitude > 0)) {
    g.reason = "the neck did not move";
    return g;
  }
  g.gain = pan.amplitude / neck.amplitude;
  g.gain_sigma =
      g.gain * std::hypot(pan.amplitude_sigma / std::max(pan.amplitude, 1e-12), neck.amplitude_sigma / neck.amplitude);
  // A perfect VOR: pan = -neck, i.e. the eye's phase is the neck's + 180 deg. The lag is how much
  // less the eye's phase is than that.
  const double lag = Wrap(neck.phase_rad + M_PI - pan.phase_rad);
  g.lag_deg = lag * kRadToDeg;
  g.lag_sigma_deg = std::hypot(neck.phase_sigma_rad, pan.phase_sigma_rad) * kRadToDeg;
  g.lag_ms = 1000 * lag / (2 * M_PI * hz);
  g.lag_sigma_ms = 1000 * std::hypot(neck.phase_sigma_rad, pan.phase_sigma_rad) / (2 * M_PI * hz);
  g.ok = true;
  return g;
}

VorGain StepGain(const std::vector<double>& t,
                 const std::vector<double>& neck,
                 const std::vector<double>& pan,
                 double lead_s,
                 double hold_s) {
  VorGain g;
  if (t.size() != neck.size() || t.size() != pan.size()) {
    g.reason = "times and values differ in length";
    return g;
  }
  const MeanVar n0 = Window(t, neck, 0, lead_s), p0 = Window(t, pan, 0, lead_s);
  const double a = lead_s + hold_s * 2 / 3, b = lead_s + hold_s;
  const MeanVar n1 = Window(t, neck, a, b), p1 = Window(t, pan, a, b);
  if (n0.n < 2 || n1.n < 2 || p0.n < 2 || p1.n < 2) {
    g.reason = "fewer than 2 samples before the step or at the end of its hold";
    return g;
  }
  const double dn = n1.mean - n0.mean, dp = p1.mean - p0.mean;
  if (std::abs(dn) < 1e-9) {
    g.reason = "the neck did not move";
    return g;
  }
  g.gain = -dp / dn;
  const double sdn = std::sqrt(n0.var / n0.n + n1.var / n1.n), sdp = std::sqrt(p0.var / p0.n + p1.var / p1.n);
  g.gain_sigma = std::hypot(sdp / std::abs(dn), std::abs(dp) * sdn / (dn * dn));
  g.ok = true;
  return g;
}

SlipStats ComputeSlip(const std::vector<double>& t,
                      const std::vector<double>& x,
                      const std::vector<double>& angle,
                      const std::vector<bool>& found) {
  SlipStats s;
  const size_t n = std::min({t.size(), x.size(), angle.size(), found.size()});
  double x0 = 0, sum_px = 0, sum_v = 0, sum_w = 0;
  bool have0 = false;
  int prev = -1;
  for (size_t i = 0; i < n; ++i) {
    if (!found[i] || !std::isfinite(x[i])) {
      prev = -1;
      continue;
    }
    if (!have0) {
      x0 = x[i];
      have0 = true;
    }
    const double d = std::abs(x[i] - x0);
    sum_px += d * d;
    s.peak_px = std::max(s.peak_px, d);
    ++s.num_samples;
    if (prev >= 0 && t[i] > t[prev]) {
      const double dt = t[i] - t[prev];
      const double v = std::abs(x[i] - x[prev]) / dt;
      const double wv =
          std::isfinite(angle[i]) && std::isfinite(angle[prev]) ? std::abs(angle[i] - angle[prev]) / dt : 0.0;
      sum_v += v * v;
      sum_w += wv * wv;
      s.peak_px_per_s = std::max(s.peak_px_per_s, v);
      s.peak_deg_per_s = std::max(s.peak_deg_per_s, wv);
      ++s.num_velocities;
    }
    prev = int(i);
  }
  if (s.num_samples) s.rms_px = std::sqrt(sum_px / s.num_samples);
  if (s.num_velocities) {
    s.rms_px_per_s = std::sqrt(sum_v / s.num_velocities);
    s.rms_deg_per_s = std::sqrt(sum_w / s.num_velocities);
  }
  return s;
}

}  // namespace owlcal::fitting
