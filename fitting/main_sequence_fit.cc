#include "fitting/main_sequence_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>

#include <ceres/ceres.h>

#include "models/units.h"

namespace owlcal::fitting {
namespace {
constexpr double kUnbounded = std::numeric_limits<double>::infinity();
constexpr double kSlewMin = 20, kSlewMax = 5000;  // deg/s
constexpr double kLagMin = 1e-3, kLagMax = 0.3;   // s

// Y(tau) of the header: from rest, size a > 0.
template <typename T>
T StepY(const T& tau, const T& a, const T& slew, const T& lag) {
  if (!(tau > T(0))) return T(0);
  const T tr = a / slew;
  auto ramp = [&](const T& x) { return slew * (x - lag) + slew * lag * ceres::exp(-x / lag); };
  if (tau <= tr) return ramp(tau);
  const T y1 = ramp(tr);
  return a + (y1 - a) * ceres::exp(-(tau - tr) / lag);
}

// Time above v_th: the velocity rises as slew (1 - exp(-tau / lag)) while the reference ramps,
// then decays from V = slew (1 - exp(-tr / lag)) with the lag.
template <typename T>
T DurationT(const T& a, const T& slew, const T& lag, double vth) {
  const T tr = a / slew;
  const T v = slew * (T(1) - ceres::exp(-tr / lag));
  const T t_on = -lag * ceres::log(T(1) - T(vth) / slew);
  const T t_off = tr + lag * ceres::log(v / T(vth));
  return t_off - t_on;
}

struct AngleResidual {
  double t, angle;
  int dir;
  template <typename T>
  bool operator()(const T* slew, const T* lag, const T* delay, const T* theta0, const T* amp, T* r) const {
    r[0] = T(angle) - (theta0[0] + T(double(dir)) * StepY(T(t) - delay[0], amp[0], slew[0], lag[0]));
    return true;
  }
};

struct PeakResidual {
  double a, v;
  template <typename T>
  bool operator()(const T* vmax, const T* c, T* r) const {
    r[0] = T(v) - vmax[0] * (T(1) - ceres::exp(-T(a) / c[0]));
    return true;
  }
};

struct DurationResidual {
  double a, d, vth;
  template <typename T>
  bool operator()(const T* slew, const T* lag, T* r) const {
    r[0] = T(d) - DurationT(T(a), slew[0], lag[0], vth);
    return true;
  }
};

struct Prepared {
  int index = 0;  // into traces
  int dir = 1;
  double theta0 = 0, amp = 0;
  std::vector<double> t, angle;  // measured frames only
};

double Sse(const std::vector<Prepared>& ps, double slew, double lag, double delay) {
  double ss = 0;
  for (const Prepared& p : ps)
    for (size_t k = 0; k < p.t.size(); ++k) {
      const double r = p.angle[k] - (p.theta0 + p.dir * StepY(p.t[k] - delay, p.amp, slew, lag));
      ss += r * r;
    }
  return ss;
}

ceres::Solver::Options SolverOptions() {
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 200;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  so.logging_type = ceres::SILENT;
  return so;
}

// Covariance of the listed one-parameter blocks (unscaled); false when rank deficient.
bool Cov(ceres::Problem* problem, const std::vector<double*>& blocks, std::vector<std::vector<double>>* out) {
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (size_t i = 0; i < blocks.size(); ++i)
    for (size_t j = i; j < blocks.size(); ++j) pairs.push_back({blocks[i], blocks[j]});
  if (!cov.Compute(pairs, problem)) return false;
  out->assign(blocks.size(), std::vector<double>(blocks.size(), 0));
  for (size_t i = 0; i < blocks.size(); ++i)
    for (size_t j = i; j < blocks.size(); ++j) {
      double c = 0;
      cov.GetCovarianceBlock(blocks[i], blocks[j], &c);
      (*out)[i][j] = (*out)[j][i] = c;
    }
  return true;
}

// The pooled fit from the given start (slew, lag, delay, theta0, amp updated); *cov (when not
// null) the unscaled covariance of (slew, lag, delay), empty when rank deficient.
bool SolvePooled(const std::vector<Prepared>& ps,
                 const MainSequenceFitOptions& o,
                 double* slew,
                 double* lag,
                 double* delay,
                 std::vector<double>* theta0,
                 std::vector<double>* amp,
                 double* cost,
                 std::vector<std::vector<double>>* cov,
                 std::string* why) {
  ceres::Problem problem;
  for (size_t i = 0; i < ps.size(); ++i) {
    for (size_t k = 0; k < ps[i].t.size(); ++k)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<AngleResidual, 1, 1, 1, 1, 1, 1>(
                                   new AngleResidual{ps[i].t[k], ps[i].angle[k], ps[i].dir}),
                               nullptr,
                               slew,
                               lag,
                               delay,
                               &(*theta0)[i],
                               &(*amp)[i]);
    problem.SetParameterLowerBound(&(*amp)[i], 0, 0.01);
  }
  problem.SetParameterLowerBound(slew, 0, kSlewMin);
  problem.SetParameterUpperBound(slew, 0, kSlewMax);
  problem.SetParameterLowerBound(lag, 0, kLagMin);
  problem.SetParameterUpperBound(lag, 0, kLagMax);
  problem.SetParameterLowerBound(delay, 0, o.delay_min_s);
  problem.SetParameterUpperBound(delay, 0, o.delay_max_s);
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(), &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    if (why) *why = summary.message;
    return false;
  }
  *cost = summary.final_cost;
  if (cov && !Cov(&problem, {slew, lag, delay}, cov)) cov->clear();
  return true;
}

// Jackknife standard error of an estimate from its leave-one-out values.
double JackknifeSigma(const std::vector<double>& v) {
  const double n = double(v.size());
  double mean = 0;
  for (double x : v) mean += x / n;
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt((n - 1) / n * ss);
}

std::string Num(double v, int decimals) {
  if (!std::isfinite(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The saccades with enough measured frames and motion, each with its start, direction and
// amplitude from its first and last frames; the others get their reason in out->saccades.
std::vector<Prepared> PrepareSaccades(const std::vector<SaccadeTrace>& traces,
                                      const MainSequenceFitOptions& o,
                                      MainSequenceFit* out) {
  std::vector<Prepared> ps;
  for (size_t i = 0; i < traces.size(); ++i) {
    const SaccadeTrace& tr = traces[i];
    SaccadeMeasurement& m = out->saccades[i];
    m.id = tr.id;
    if (tr.t_s.size() != tr.angle_deg.size())
      throw std::invalid_argument("FitMainSequence: saccade " + std::to_string(tr.id) + ": " +
                                  std::to_string(tr.t_s.size()) + " times and " + std::to_string(tr.angle_deg.size()) +
                                  " angles");
    Prepared p;
    p.index = int(i);
    for (size_t k = 0; k < tr.t_s.size(); ++k)
      if (std::isfinite(tr.angle_deg[k]) && std::isfinite(tr.t_s[k])) {
        p.t.push_back(tr.t_s[k]);
        p.angle.push_back(tr.angle_deg[k]);
      }
    m.num_frames = int(p.t.size());
    if (int(p.t.size()) < o.rest_frames + 3) {
      m.reason = "too few measured frames (" + std::to_string(p.t.size()) + ")";
      continue;
    }
    double end = 0;
    for (int k = 0; k < o.rest_frames; ++k) end += p.angle[p.t.size() - 1 - k];
    end /= o.rest_frames;
    p.theta0 = p.angle.front();
    p.dir = end >= p.theta0 ? 1 : -1;
    p.amp = std::abs(end - p.theta0);
    if (p.amp < 0.1) {
      m.reason = "no motion: the first and last frames differ by " + Num(p.amp, 3) + " deg";
      continue;
    }
    ps.push_back(p);
  }
  return ps;
}

// Step 1, the pooled fit of every frame: a grid for the start, then the least-squares fit, its
// sigmas from the residuals and the jackknife over saccades; updates each saccade's start and
// amplitude. False (with the solver's message) when the fit fails.
bool FitPooledMotion(const MainSequenceFitOptions& o,
                     std::vector<Prepared>* prepared,
                     PooledSaccadeMotion* motion,
                     std::string* failed_message) {
  std::vector<Prepared>& ps = *prepared;
  PooledSaccadeMotion& mo = *motion;
  double best = kUnbounded, slew = 300, lag = 0.03, delay = o.delay_min_s;
  for (double s : {150.0, 250.0, 400.0, 650.0, 1000.0})
    for (double l : {0.01, 0.03, 0.06})
      for (double d = o.delay_min_s; d <= o.delay_max_s + 1e-9; d += 0.005) {
        const double e = Sse(ps, s, l, d);
        if (e < best) best = e, slew = s, lag = l, delay = d;
      }
  std::vector<double> theta0(ps.size()), amp(ps.size());
  for (size_t i = 0; i < ps.size(); ++i) {
    theta0[i] = ps[i].theta0;
    amp[i] = ps[i].amp;
  }
  std::vector<std::vector<double>> c;
  double cost = 0;
  std::string failed;
  if (!SolvePooled(ps, o, &slew, &lag, &delay, &theta0, &amp, &cost, &c, &failed)) {
    *failed_message = failed;
    return false;
  }
  const int n = mo.num_frames, np = 3 + 2 * int(ps.size());
  const double s2 = 2 * cost / std::max(1, n - np);
  mo.ok = true;
  mo.slew_deg_per_s = slew;
  mo.lag_s = lag;
  mo.delay_s = delay;
  mo.rms_deg = std::sqrt(2 * cost / n);
  if (!c.empty()) {
    mo.fit_slew_sigma_deg_per_s = std::sqrt(std::max(0.0, c[0][0] * s2));
    mo.fit_lag_sigma_s = std::sqrt(std::max(0.0, c[1][1] * s2));
    mo.fit_delay_sigma_s = std::sqrt(std::max(0.0, c[2][2] * s2));
  } else {
    mo.fit_slew_sigma_deg_per_s = mo.fit_lag_sigma_s = mo.fit_delay_sigma_s = kUnbounded;
  }
  // The frames of one saccade share their errors (the disc's centroid, the servo's step and
  // backlash, where the frame clock fell): the residual-based covariance treats 16 frames as 16
  // independent draws and is too small (default robot: the slew 381.9 +- 0.3 against 380, 6.3
  // sigma). Jackknife over saccades: the pooled fit again without each one in turn.
  std::vector<double> js, jl, jd;
  for (size_t leave = 0; leave < ps.size(); ++leave) {
    std::vector<Prepared> sub;
    std::vector<double> th, am;
    for (size_t i = 0; i < ps.size(); ++i)
      if (i != leave) {
        sub.push_back(ps[i]);
        th.push_back(theta0[i]);
        am.push_back(amp[i]);
      }
    double sl = slew, lg = lag, de = delay, co = 0;
    if (SolvePooled(sub, o, &sl, &lg, &de, &th, &am, &co, nullptr, nullptr)) {
      js.push_back(sl);
      jl.push_back(lg);
      jd.push_back(de);
    }
  }
  mo.jackknife_saccades = int(js.size());
  if (js.size() >= 3) {
    mo.jackknife_slew_sigma_deg_per_s = JackknifeSigma(js);
    mo.jackknife_lag_sigma_s = JackknifeSigma(jl);
    mo.jackknife_delay_sigma_s = JackknifeSigma(jd);
  }
  mo.scale_slew_sigma_deg_per_s = o.angle_scale_sigma * slew;
  mo.slew_sigma_deg_per_s = std::hypot(std::max(mo.fit_slew_sigma_deg_per_s, mo.jackknife_slew_sigma_deg_per_s),
                                       mo.scale_slew_sigma_deg_per_s);
  mo.lag_sigma_s = std::max(mo.fit_lag_sigma_s, mo.jackknife_lag_sigma_s);
  mo.delay_sigma_s = std::max(mo.fit_delay_sigma_s, mo.jackknife_delay_sigma_s);
  for (size_t i = 0; i < ps.size(); ++i) {
    ps[i].theta0 = theta0[i];
    ps[i].amp = amp[i];
  }
  mo.message = "slew " + Num(slew, 1) + " +- " + Num(mo.slew_sigma_deg_per_s, 1) + " deg/s, lag " + Num(1000 * lag, 2) +
               " +- " + Num(1000 * mo.lag_sigma_s, 2) + " ms, delay " + Num(1000 * delay, 2) + " +- " +
               Num(1000 * mo.delay_sigma_s, 2) + " ms (sigmas: the larger of the fit's and the jackknife's over " +
               std::to_string(mo.jackknife_saccades) + " saccades; the slew's with " +
               Num(100 * o.angle_scale_sigma, 1) + " % of angle scale), RMS " + Num(mo.rms_deg, 4) + " deg over " +
               std::to_string(n) + " frames of " + std::to_string(ps.size()) + " saccades";
  return true;
}

// Step 2, one saccade: its own slew with the pooled lag and delay, its peak velocity and duration
// with their sigmas.
void MeasureSaccade(const Prepared& p, const PooledSaccadeMotion& mo, double vth, SaccadeMeasurement* out) {
  const double s2_pooled = mo.rms_deg * mo.rms_deg;
  SaccadeMeasurement& m = *out;
  double s = mo.slew_deg_per_s, l = mo.lag_s, d = mo.delay_s, th = p.theta0, a = p.amp;
  ceres::Problem problem;
  for (size_t k = 0; k < p.t.size(); ++k)
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<AngleResidual, 1, 1, 1, 1, 1, 1>(new AngleResidual{p.t[k], p.angle[k], p.dir}),
        nullptr,
        &s,
        &l,
        &d,
        &th,
        &a);
  problem.SetParameterBlockConstant(&l);
  problem.SetParameterBlockConstant(&d);
  problem.SetParameterLowerBound(&s, 0, kSlewMin);
  problem.SetParameterUpperBound(&s, 0, kSlewMax);
  problem.SetParameterLowerBound(&a, 0, 0.01);
  ceres::Solver::Summary summary;
  ceres::Solve(SolverOptions(), &problem, &summary);
  if (!summary.IsSolutionUsable()) {
    m.reason = "its fit failed: " + summary.message;
    return;
  }
  m.direction = p.dir;
  m.start_deg = th;
  m.amplitude_deg = a;
  m.slew_deg_per_s = s;
  m.rms_deg = std::sqrt(2 * summary.final_cost / p.t.size());
  m.peak_deg_per_s = PeakVelocityDegPerS(a, s, l);
  m.duration_s = DurationS(a, s, l, vth);
  std::vector<std::vector<double>> c;
  if (Cov(&problem, {&s, &a}, &c)) {
    m.slew_sigma_deg_per_s = std::sqrt(std::max(0.0, c[0][0] * s2_pooled));
    m.amplitude_sigma_deg = std::sqrt(std::max(0.0, c[1][1] * s2_pooled));
    // Peak velocity and duration: first-order propagation of (slew, a).
    auto prop = [&](auto f) {
      const double hs = 1e-4 * s, ha = 1e-4 * a;
      const double gs = (f(a, s + hs) - f(a, s - hs)) / (2 * hs);
      const double ga = (f(a + ha, s) - f(a - ha, s)) / (2 * ha);
      const double v = (gs * gs * c[0][0] + 2 * gs * ga * c[0][1] + ga * ga * c[1][1]) * s2_pooled;
      return std::sqrt(std::max(0.0, v));
    };
    m.peak_sigma_deg_per_s = prop([&](double aa, double ss) { return PeakVelocityDegPerS(aa, ss, l); });
    m.duration_sigma_s =
        std::isfinite(m.duration_s) ? prop([&](double aa, double ss) { return DurationS(aa, ss, l, vth); }) : kNaN;
  } else {
    m.slew_sigma_deg_per_s = m.amplitude_sigma_deg = m.peak_sigma_deg_per_s = m.duration_sigma_s = kUnbounded;
  }
  m.ok = true;
}

// Step 3a, the main sequence V = Vmax (1 - exp(-A / C)) over the measured saccades.
void FitPeakCurve(const std::vector<SaccadeMeasurement>& saccades,
                  const PooledSaccadeMotion& mo,
                  const MainSequenceFitOptions& o,
                  MainSequenceCurve* out) {
  MainSequenceCurve& cu = *out;
  double vmax = 0, cdeg = 0;
  ceres::Problem problem;
  for (const SaccadeMeasurement& m : saccades)
    if (m.ok) {
      vmax = std::max(vmax, m.peak_deg_per_s);
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<PeakResidual, 1, 1, 1>(new PeakResidual{m.amplitude_deg, m.peak_deg_per_s}),
          nullptr,
          &vmax,
          &cdeg);
      ++cu.num_saccades;
    }
  if (cu.num_saccades < 3) {
    cu.message = "too few measured saccades (" + std::to_string(cu.num_saccades) + ")";
  } else {
    cdeg = vmax * mo.lag_s;
    problem.SetParameterLowerBound(&vmax, 0, 1);
    problem.SetParameterLowerBound(&cdeg, 0, 1e-3);
    ceres::Solver::Summary summary;
    ceres::Solve(SolverOptions(), &problem, &summary);
    const int n = cu.num_saccades;
    const double s2 = 2 * summary.final_cost / std::max(1, n - 2);
    std::vector<std::vector<double>> c;
    cu.ok = summary.IsSolutionUsable();
    cu.vmax_deg_per_s = vmax;
    cu.c_deg = cdeg;
    cu.lag_s = cdeg / vmax;
    cu.rms_deg_per_s = std::sqrt(2 * summary.final_cost / n);
    if (cu.ok && Cov(&problem, {&vmax, &cdeg}, &c)) {
      cu.vmax_sigma_deg_per_s = std::hypot(std::sqrt(std::max(0.0, c[0][0] * s2)), o.angle_scale_sigma * vmax);
      cu.c_sigma_deg = std::hypot(std::sqrt(std::max(0.0, c[1][1] * s2)), o.angle_scale_sigma * cdeg);
      const double gv = -cdeg / (vmax * vmax), gc = 1 / vmax;
      cu.lag_sigma_s = std::sqrt(std::max(0.0, (gv * gv * c[0][0] + 2 * gv * gc * c[0][1] + gc * gc * c[1][1]) * s2));
    } else {
      cu.vmax_sigma_deg_per_s = cu.c_sigma_deg = cu.lag_sigma_s = kUnbounded;
    }
    cu.message = cu.ok
                     ? "Vmax " + Num(vmax, 1) + " +- " + Num(cu.vmax_sigma_deg_per_s, 1) + " deg/s, C " + Num(cdeg, 2) +
                           " +- " + Num(cu.c_sigma_deg, 2) + " deg over " + std::to_string(n) + " saccades"
                     : "the fit failed: " + summary.message;
  }
}

// Step 3b, duration against amplitude (the servo law) over the saccades with a duration.
void FitDurationCurve(const std::vector<SaccadeMeasurement>& saccades,
                      const PooledSaccadeMotion& mo,
                      const MainSequenceFitOptions& o,
                      DurationCurve* out) {
  const double vth = o.velocity_threshold_deg_per_s;
  DurationCurve& du = *out;
  double s = mo.slew_deg_per_s, l = mo.lag_s;
  ceres::Problem problem;
  for (const SaccadeMeasurement& m : saccades)
    if (m.ok && std::isfinite(m.duration_s)) {
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<DurationResidual, 1, 1, 1>(
                                   new DurationResidual{m.amplitude_deg, m.duration_s, vth}),
                               nullptr,
                               &s,
                               &l);
      ++du.num_saccades;
    }
  if (du.num_saccades < 3) {
    du.message = "too few saccades with a duration (" + std::to_string(du.num_saccades) + ")";
  } else {
    problem.SetParameterLowerBound(&s, 0, 2 * vth);
    problem.SetParameterUpperBound(&s, 0, kSlewMax);
    problem.SetParameterLowerBound(&l, 0, kLagMin);
    problem.SetParameterUpperBound(&l, 0, kLagMax);
    ceres::Solver::Summary summary;
    ceres::Solve(SolverOptions(), &problem, &summary);
    const int n = du.num_saccades;
    const double s2 = 2 * summary.final_cost / std::max(1, n - 2);
    du.ok = summary.IsSolutionUsable();
    du.slew_deg_per_s = s;
    du.lag_s = l;
    du.rms_s = std::sqrt(2 * summary.final_cost / n);
    std::vector<std::vector<double>> c;
    if (du.ok && Cov(&problem, {&s, &l}, &c)) {
      du.slew_sigma_deg_per_s = std::hypot(std::sqrt(std::max(0.0, c[0][0] * s2)), o.angle_scale_sigma * s);
      du.lag_sigma_s = std::sqrt(std::max(0.0, c[1][1] * s2));
    } else {
      du.slew_sigma_deg_per_s = du.lag_sigma_s = kUnbounded;
    }
    du.message = du.ok ? "slew " + Num(s, 1) + " +- " + Num(du.slew_sigma_deg_per_s, 1) + " deg/s, lag " +
                             Num(1000 * l, 2) + " +- " + Num(1000 * du.lag_sigma_s, 2) + " ms over " +
                             std::to_string(n) + " saccades"
                       : "the fit failed: " + summary.message;
  }
}

}  // namespace

bool MainSequenceFitOptions::Check(std::string* why) const {
  std::string r;
  if (!(delay_min_s >= 0) || !(delay_max_s > delay_min_s))
    r = "need 0 <= delay_min_s < delay_max_s";
  else if (rest_frames < 1)
    r = "rest_frames must be >= 1";
  else if (!(velocity_threshold_deg_per_s > 0))
    r = "velocity_threshold_deg_per_s must be > 0";
  else if (!(angle_scale_sigma >= 0 && angle_scale_sigma < 1))
    r = "angle_scale_sigma must be in [0, 1)";
  if (r.empty()) return true;
  if (why) *why = "MainSequenceFitOptions: " + r;
  return false;
}

double SaccadeAngleDeg(double tau_s, double amplitude_deg, double slew_deg_per_s, double lag_s) {
  const double a = std::abs(amplitude_deg);
  return (amplitude_deg < 0 ? -1 : 1) * StepY(tau_s, a, slew_deg_per_s, std::max(lag_s, 1e-9));
}

double PeakVelocityDegPerS(double amplitude_deg, double slew_deg_per_s, double lag_s) {
  if (lag_s <= 0) return slew_deg_per_s;
  return slew_deg_per_s * (1 - std::exp(-std::abs(amplitude_deg) / (slew_deg_per_s * lag_s)));
}

double DurationS(double amplitude_deg, double slew_deg_per_s, double lag_s, double vth) {
  const double a = std::abs(amplitude_deg);
  if (!(PeakVelocityDegPerS(a, slew_deg_per_s, lag_s) > vth) || !(lag_s > 0)) return kNaN;
  return DurationT(a, slew_deg_per_s, lag_s, vth);
}

MainSequenceFit FitMainSequence(const std::vector<SaccadeTrace>& traces, const MainSequenceFitOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  MainSequenceFit out;
  out.velocity_threshold_deg_per_s = o.velocity_threshold_deg_per_s;
  out.saccades.resize(traces.size());
  std::vector<Prepared> ps = PrepareSaccades(traces, o, &out);
  PooledSaccadeMotion& mo = out.motion;
  mo.num_saccades = int(ps.size());
  for (const Prepared& p : ps) mo.num_frames += int(p.t.size());
  // Everything below needs the pooled fit: when it cannot be made, every saccade says so.
  auto not_measured = [&](const std::string& why) {
    mo.message = why;
    for (const Prepared& p : ps) out.saccades[p.index].reason = "not measured: " + why;
    out.peak.message = out.duration.message = "no pooled fit: " + why;
    return out;
  };
  if (ps.size() < 3) return not_measured("too few saccades with measured motion (" + std::to_string(ps.size()) + ")");

  // 1. Pooled: a grid for the start, then the least-squares fit.
  std::string failed;
  if (!FitPooledMotion(o, &ps, &mo, &failed)) return not_measured("the pooled fit failed: " + failed);

  // 2. Per saccade: its own slew, the pooled lag and delay.
  const double vth = o.velocity_threshold_deg_per_s;
  for (const Prepared& p : ps) MeasureSaccade(p, mo, vth, &out.saccades[p.index]);

  // 3. The main-sequence curves.
  FitPeakCurve(out.saccades, mo, o, &out.peak);
  FitDurationCurve(out.saccades, mo, o, &out.duration);
  return out;
}

}  // namespace owlcal::fitting
