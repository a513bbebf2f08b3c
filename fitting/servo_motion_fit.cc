#include "fitting/servo_motion_fit.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

#include "models/slew_lag.h"

namespace owlcal::fitting {
namespace {

struct Params {
  double log_slew = 0, lag = 0, delay = 0;
};

// Joint positions at every measured frame's exposure, per segment, for one parameter set.
struct Evaluation {
  std::vector<double> residuals;
  double px_per_us = 0;
  double rms = std::numeric_limits<double>::infinity();
};

class Problem {
 public:
  Problem(const std::vector<MotionSegment>& segs, const ServoMotionFitOptions& o) : segs_(segs), o_(o) {}

  Evaluation Evaluate(const Params& p) const {
    const double slew = std::exp(p.log_slew);
    std::vector<std::vector<double>> pos(segs_.size());
    // Per segment: joint positions at the exposures of the measured frames.
    for (size_t s = 0; s < segs_.size(); ++s) {
      const MotionSegment& seg = segs_[s];
      models::ServoState st{o_.resolution.Stepped(seg.frames.front().command_us), seg.initial_approach};
      auto target = [&](const models::ServoState& x) { return x.applied_us - o_.hysteresis_us * x.approach; };
      models::SlewLagTrajectory joint(slew, p.lag, seg.frames.front().t_s - 10.0, target(st));
      for (size_t k = 1; k < seg.frames.size(); ++k) {
        if (seg.frames[k].command_us != seg.frames[k - 1].command_us) {
          const models::ServoState next = o_.resolution.Next(st, seg.frames[k].command_us);
          if (!(next == st)) {
            st = next;
            joint.Command(seg.frames[k - 1].t_s + o_.command_delay_s, target(st));
          }
        }
      }
      for (const MotionFrame& f : seg.frames)
        if (f.found) pos[s].push_back(joint.At(f.t_s - p.delay));
    }
    // offset = a_s - b * pos: centre per segment, then b in closed form.
    double num = 0, den = 0;
    std::vector<double> mean_e(segs_.size(), 0), mean_p(segs_.size(), 0);
    for (size_t s = 0; s < segs_.size(); ++s) {
      size_t i = 0;
      for (const MotionFrame& f : segs_[s].frames)
        if (f.found) {
          mean_e[s] += f.offset_px;
          mean_p[s] += pos[s][i++];
        }
      if (i > 0) {
        mean_e[s] /= double(i);
        mean_p[s] /= double(i);
      }
      i = 0;
      for (const MotionFrame& f : segs_[s].frames)
        if (f.found) {
          const double pe = pos[s][i++] - mean_p[s];
          num += (f.offset_px - mean_e[s]) * pe;
          den += pe * pe;
        }
    }
    Evaluation ev;
    if (!(den > 0)) return ev;
    const double b = -num / den;
    double ss = 0;
    for (size_t s = 0; s < segs_.size(); ++s) {
      size_t i = 0;
      for (const MotionFrame& f : segs_[s].frames)
        if (f.found) {
          const double r = (f.offset_px - mean_e[s]) + b * (pos[s][i++] - mean_p[s]);
          ev.residuals.push_back(r);
          ss += r * r;
        }
    }
    ev.px_per_us = -b;
    ev.rms = ev.residuals.empty() ? ev.rms : std::sqrt(ss / double(ev.residuals.size()));
    return ev;
  }

 private:
  const std::vector<MotionSegment>& segs_;
  const ServoMotionFitOptions& o_;
};

// Grid search then Nelder-Mead over the parameters marked free (log slew, lag, delay); the others
// stay at `start`. The delay is kept inside its window, the lag >= 0.
Params Search(const Problem& problem, const ServoMotionFitOptions& o, const std::array<bool, 3>& free, Params start) {
  // Grid: slew 800-20000 us/s (90-2260 deg/s at 0.113 deg/us), lag 0-150 ms, delay over its window.
  const int ns = free[0] ? 14 : 1, nl = free[1] ? 31 : 1, nd = free[2] ? 7 : 1;
  if (!free[2]) start.delay = std::max(start.delay, o.exposure_delay_min_s);
  Params best = start;
  double best_rms = std::numeric_limits<double>::infinity();
  for (int i = 0; i < ns; ++i)
    for (int j = 0; j < nl; ++j)
      for (int k = 0; k < nd; ++k) {
        Params p = start;
        if (free[0]) p.log_slew = std::log(800.0) + i * (std::log(20000.0) - std::log(800.0)) / 13.0;
        if (free[1]) p.lag = 0.005 * j;
        if (free[2])
          p.delay = o.exposure_delay_min_s + k * (o.exposure_delay_max_s - o.exposure_delay_min_s) / (nd - 1);
        const double rms = problem.Evaluate(p).rms;
        if (rms < best_rms) {
          best_rms = rms;
          best = p;
        }
      }
  // Refine with Nelder-Mead (the three are correlated: a coordinate search stalls).
  std::vector<int> dims;
  for (int c = 0; c < 3; ++c)
    if (free[c]) dims.push_back(c);
  const int dim = int(dims.size());
  if (dim == 0) return best;
  auto to_params = [&](const Eigen::Vector3d& x) {
    Params p{
        x[0], std::max(0.0, x[1]), free[2] ? std::clamp(x[2], o.exposure_delay_min_s, o.exposure_delay_max_s) : x[2]};
    return p;
  };
  auto cost = [&](const Eigen::Vector3d& x) {
    const Params p = to_params(x);
    double c = problem.Evaluate(p).rms;
    if (x[1] < 0) c += -x[1];  // outside the box: penalised
    if (free[2] && (x[2] < o.exposure_delay_min_s || x[2] > o.exposure_delay_max_s)) c += 1.0;
    return c;
  };
  std::vector<Eigen::Vector3d> simplex(dim + 1, Eigen::Vector3d(best.log_slew, best.lag, best.delay));
  const double step[3] = {0.15, 0.005, 0.004};
  for (int i = 0; i < dim; ++i) simplex[i + 1][dims[i]] += step[dims[i]];
  std::vector<double> f(dim + 1);
  for (int i = 0; i <= dim; ++i) f[i] = cost(simplex[i]);
  for (int it = 0; it < 400 && dim > 0; ++it) {
    std::vector<int> idx(dim + 1);
    for (int i = 0; i <= dim; ++i) idx[i] = i;
    std::sort(idx.begin(), idx.end(), [&](int a, int b) { return f[a] < f[b]; });
    const int lo = idx[0], hi = idx[dim], nh = idx[std::max(0, dim - 1)];
    if (f[hi] - f[lo] < 1e-9 * (1 + f[lo])) break;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (int i = 0; i <= dim; ++i)
      if (i != hi) c += simplex[i];
    c /= dim;
    const Eigen::Vector3d xr = c + (c - simplex[hi]);
    const double fr = cost(xr);
    if (fr < f[lo]) {
      const Eigen::Vector3d xe = c + 2 * (c - simplex[hi]);
      const double fe = cost(xe);
      if (fe < fr)
        simplex[hi] = xe, f[hi] = fe;
      else
        simplex[hi] = xr, f[hi] = fr;
    } else if (fr < f[nh]) {
      simplex[hi] = xr, f[hi] = fr;
    } else {
      const Eigen::Vector3d xc = c + 0.5 * (simplex[hi] - c);
      const double fc = cost(xc);
      if (fc < f[hi]) {
        simplex[hi] = xc, f[hi] = fc;
      } else {
        for (int i = 0; i <= dim; ++i)
          if (i != lo) simplex[i] = simplex[lo] + 0.5 * (simplex[i] - simplex[lo]), f[i] = cost(simplex[i]);
      }
    }
  }
  int bi = 0;
  for (int i = 1; i <= dim; ++i)
    if (f[i] < f[bi]) bi = i;
  if (f[bi] < best_rms) best = to_params(simplex[bi]);
  return best;
}

// Sigmas of the free parameters (sigma[0] of log slew, i.e. relative; lag [s]; delay [s]; 0 for a
// held one): J^T J of the residuals (a, px_per_us re-solved), scaled by the residual variance. A
// parameter whose relative sigma is above 30 % (the lag: above max(30 %, 3 ms)) is not determined.
struct Sigmas {
  std::array<double, 3> sigma{0, 0, 0};
  std::array<bool, 3> determined{false, false, false};
};
Sigmas ParamSigmas(const Problem& problem, const Params& best, const std::array<bool, 3>& free, int num_segments) {
  Sigmas out;
  const Evaluation ev = problem.Evaluate(best);
  std::vector<int> dims;
  for (int c = 0; c < 3; ++c)
    if (free[c]) dims.push_back(c);
  const int n = int(ev.residuals.size());
  const int np = int(dims.size());
  if (np == 0 || n == 0) return out;
  Eigen::MatrixXd J(n, np);
  const double h[3] = {0.02, 0.001, 0.001};
  for (int col = 0; col < np; ++col) {
    const int c = dims[col];
    Params up = best, dn = best;
    double Params::*f = c == 0 ? &Params::log_slew : (c == 1 ? &Params::lag : &Params::delay);
    up.*f += h[c];
    dn.*f -= h[c];
    if (c == 1 && dn.lag < 0) dn.lag = 0;
    const double step = up.*f - dn.*f;
    const Evaluation eu = problem.Evaluate(up), ed = problem.Evaluate(dn);
    for (int i = 0; i < n; ++i)
      J(i, col) = (i < int(eu.residuals.size()) && i < int(ed.residuals.size()))
                      ? (eu.residuals[i] - ed.residuals[i]) / step
                      : 0;
  }
  const double s2 = ev.rms * ev.rms * n / std::max(1, n - np - 1 - num_segments);
  const Eigen::MatrixXd info = J.transpose() * J;
  Eigen::FullPivLU<Eigen::MatrixXd> lu(info);
  const double big = std::numeric_limits<double>::infinity();
  Eigen::MatrixXd cov = Eigen::MatrixXd::Constant(np, np, big);
  if (lu.rank() == np) cov = lu.inverse() * s2;
  for (int col = 0; col < np; ++col) out.sigma[dims[col]] = std::sqrt(std::max(0.0, cov(col, col)));
  const double slew = std::exp(best.log_slew);
  out.determined[0] = free[0] && std::isfinite(out.sigma[0]) && slew * out.sigma[0] < 0.3 * slew;
  out.determined[1] = free[1] && std::isfinite(out.sigma[1]) && out.sigma[1] < std::max(0.3 * best.lag, 0.003);
  out.determined[2] = free[2] && std::isfinite(out.sigma[2]);
  return out;
}

}  // namespace

bool ServoMotionFitOptions::Check(std::string* why) const {
  std::string r;
  if (!(fps > 0))
    r = "fps must be > 0";
  else if (!(exposure_delay_min_s >= 0) || !(exposure_delay_max_s >= exposure_delay_min_s))
    r = "need 0 <= exposure delay min <= max";
  else if (!(command_delay_s >= 0) || !(hysteresis_us >= 0))
    r = "command delay and hysteresis must be >= 0";
  else if (!(prior_slew_us_per_s >= 0) || !std::isfinite(prior_slew_us_per_s) || !std::isfinite(prior_lag_s))
    r = "prior_slew_us_per_s must be finite and >= 0, prior_lag_s finite";
  else if (!resolution.Check(&r)) {
  }
  if (r.empty()) return true;
  if (why) *why = "ServoMotionFitOptions: " + r;
  return false;
}

ServoMotionFit FitServoMotion(const std::vector<MotionSegment>& segments, const ServoMotionFitOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  ServoMotionFit out;
  std::vector<MotionSegment> segs;
  for (const MotionSegment& s : segments) {
    int found = 0;
    bool moved = false;
    for (size_t k = 0; k < s.frames.size(); ++k) {
      found += s.frames[k].found;
      if (k > 0 && !(s.frames[k].t_s > s.frames[k - 1].t_s))
        throw std::invalid_argument("FitServoMotion: segment '" + s.name + "': frame times do not increase at frame " +
                                    std::to_string(k));
      moved |= s.frames[k].command_us != s.frames.front().command_us;
    }
    if (found >= 3 && moved) segs.push_back(s);
  }
  out.num_segments = int(segs.size());
  for (const auto& s : segs)
    for (const auto& f : s.frames) out.num_frames += f.found;
  if (segs.empty() || out.num_frames < 10) {
    out.message = "too few step frames with a command change (" + std::to_string(out.num_frames) + " frames in " +
                  std::to_string(segs.size()) + " segments)";
    return out;
  }
  const Problem problem(segs, o);
  const int nd = o.exposure_delay_max_s > o.exposure_delay_min_s ? 7 : 1;
  // The search over every parameter; then the slew, if the data do not determine it and it has a
  // prior, held at the prior and the rest fitted again; then the same for the lag (judged with the
  // slew held: a slew running off drags the lag's sigma along with it).
  std::array<bool, 3> free = {true, true, nd > 1};
  Params best = Search(problem, o, free, Params{});
  Sigmas sig = ParamSigmas(problem, best, free, int(segs.size()));
  const bool slew_prior = !sig.determined[0] && o.prior_slew_us_per_s > 0;
  if (slew_prior) {
    best.log_slew = std::log(o.prior_slew_us_per_s);
    free[0] = false;
    best = Search(problem, o, free, best);
    sig = ParamSigmas(problem, best, free, int(segs.size()));
  }
  const bool lag_prior = !sig.determined[1] && o.prior_lag_s >= 0;
  if (lag_prior) {
    best.lag = o.prior_lag_s;
    free[1] = false;
    best = Search(problem, o, free, best);
    sig = ParamSigmas(problem, best, free, int(segs.size()));
  }
  const Evaluation ev = problem.Evaluate(best);
  out.ok = std::isfinite(ev.rms);
  if (!out.ok) {
    out.message = "the step frames show no motion that follows the commands";
    return out;
  }
  out.slew_us_per_s = std::exp(best.log_slew);
  out.lag_s = best.lag;
  out.exposure_delay_s = best.delay;
  out.px_per_us = ev.px_per_us;
  out.rms_px = ev.rms;
  out.slew_sigma_us_per_s = out.slew_us_per_s * sig.sigma[0];
  out.lag_sigma_s = sig.sigma[1];
  out.exposure_delay_sigma_s = sig.sigma[2];
  out.slew_from_prior = slew_prior;
  out.lag_from_prior = lag_prior;
  out.slew_determined = !slew_prior && sig.determined[0];
  out.lag_determined = !lag_prior && sig.determined[1];
  out.message = "slew " + std::to_string(int(std::lround(out.slew_us_per_s))) + " us/s" +
                (slew_prior ? " (prior: not determined)" : "") + ", lag " +
                std::to_string(out.lag_s * 1000).substr(0, 5) + " ms" + (lag_prior ? " (prior: not determined)" : "") +
                ", exposure delay " + std::to_string(out.exposure_delay_s * 1000).substr(0, 5) + " ms, RMS " +
                std::to_string(out.rms_px).substr(0, 5) + " px over " + std::to_string(out.num_frames) + " frames";
  return out;
}

}  // namespace owlcal::fitting
