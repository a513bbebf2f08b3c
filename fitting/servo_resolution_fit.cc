#include "fitting/servo_resolution_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include <Eigen/Dense>

namespace owlcal::fitting {
namespace {

struct Replay {
  std::vector<int> applied;
  std::vector<int> approach;
  bool SameAs(const Replay& o) const {
    if (applied.size() != o.applied.size()) return false;
    for (size_t k = 0; k < applied.size(); ++k)
      if (applied[k] - applied[0] != o.applied[k] - o.applied[0] || approach[k] != o.approach[k]) return false;
    return true;
  }
};

Replay ReplayCommands(const models::ServoResolution& r, const std::vector<ResolutionSample>& samples, int approach0) {
  Replay out;
  models::ServoState s{r.Stepped(samples.front().command_us), approach0};
  for (size_t k = 0; k < samples.size(); ++k) {
    if (k > 0) s = r.Next(s, samples[k].command_us);
    out.applied.push_back(s.applied_us);
    out.approach.push_back(s.approach);
  }
  return out;
}

struct LinearFit {
  double rms = std::numeric_limits<double>::infinity();
  double px_per_us = 0, hysteresis_us = 0;
  bool ok = false;
};

// position = offset + s * a - (s h) * approach, by least squares over the measured samples.
LinearFit FitLinear(const Replay& rp, const std::vector<ResolutionSample>& samples) {
  std::vector<int> rows;
  for (size_t k = 0; k < samples.size(); ++k)
    if (std::isfinite(samples[k].position_px)) rows.push_back(int(k));
  LinearFit f;
  const int n = int(rows.size());
  if (n < 4) return f;
  bool approach_varies = false;
  for (int k : rows) approach_varies |= rp.approach[k] != rp.approach[rows[0]];
  const int cols = approach_varies ? 3 : 2;
  Eigen::MatrixXd A(n, cols);
  Eigen::VectorXd b(n);
  for (int i = 0; i < n; ++i) {
    const int k = rows[i];
    A(i, 0) = 1.0;
    A(i, 1) = rp.applied[k] - rp.applied[rows[0]];
    if (approach_varies) A(i, 2) = rp.approach[k];
    b[i] = samples[k].position_px;
  }
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  if (qr.rank() < cols) return f;
  const Eigen::VectorXd x = qr.solve(b);
  f.rms = std::sqrt((A * x - b).squaredNorm() / n);
  f.px_per_us = x[1];
  f.hysteresis_us = approach_varies && x[1] != 0 ? -x[2] / x[1] : 0.0;
  f.ok = std::isfinite(f.rms);
  return f;
}

std::string Name(const models::ServoResolution& r) {
  return "step " + std::to_string(r.step_us) + " us, dead band " + std::to_string(r.dead_band_us) + " us, phase " +
         std::to_string(r.phase_us);
}

}  // namespace

bool ResolutionFitOptions::Check(std::string* why) const {
  if (max_step_us < 1 || max_step_us > 50 || max_dead_band_us < 1 || max_dead_band_us > 50 ||
      (initial_approach != -1 && initial_approach != 0 && initial_approach != 1) || !(min_rms_ratio >= 1)) {
    if (why)
      *why =
          "ResolutionFitOptions: need 1 <= max_step_us, max_dead_band_us <= 50, initial_approach in {-1, 0, 1}, "
          "min_rms_ratio >= 1";
    return false;
  }
  return true;
}

std::string DescribeResolution(const ResolutionFit& f) {
  const models::ServoResolution& r = f.resolution;
  std::string s = "step " + std::to_string(r.step_us) + " us";
  if (r.step_us > 1) s += " (phase " + std::to_string(r.phase_us) + ")";
  if (f.dead_band_determined)
    s += ", dead band " + std::to_string(r.dead_band_us) + " us";
  else
    s += ", dead band " + std::to_string(f.dead_band_min_us) + "-" + std::to_string(f.dead_band_max_us) + " us";
  return s;
}

ResolutionFit FitServoResolution(const std::vector<ResolutionSample>& samples, const ResolutionFitOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  ResolutionFit out;
  for (const auto& s : samples) out.num_samples += std::isfinite(s.position_px);
  if (samples.empty() || out.num_samples < 8) {
    out.message = "only " + std::to_string(out.num_samples) + " measured samples (need 8)";
    return out;
  }
  // Candidates from the simplest: step, then dead band, then the rounding phase first.
  struct Candidate {
    models::ServoResolution r;
    Replay replay;
    LinearFit fit;
  };
  std::vector<Candidate> cands;
  for (int step = 1; step <= o.max_step_us; ++step) {
    for (int dead = 1; dead <= o.max_dead_band_us; ++dead) {
      std::vector<int> phases = {models::ServoResolution::DefaultPhase(step)};
      for (int p = 0; p < step; ++p)
        if (p != phases[0]) phases.push_back(p);
      for (int p : phases) {
        Candidate c;
        c.r = models::ServoResolution{step, dead, p};
        c.replay = ReplayCommands(c.r, samples, o.initial_approach);
        c.fit = FitLinear(c.replay, samples);
        if (c.fit.ok) cands.push_back(std::move(c));
      }
    }
  }
  if (cands.empty()) {
    out.message = "no candidate resolution could be fitted (the sweep shows no motion)";
    return out;
  }
  size_t best = 0;
  for (size_t i = 1; i < cands.size(); ++i)
    if (cands[i].fit.rms < cands[best].fit.rms - 1e-12) best = i;
  const Candidate& b = cands[best];
  out.ok = true;
  out.resolution = b.r;
  out.px_per_us = b.fit.px_per_us;
  out.hysteresis_us = b.fit.hysteresis_us;
  out.rms_px = b.fit.rms;
  out.applied_us = b.replay.applied;
  out.runner_up_rms_px = std::numeric_limits<double>::quiet_NaN();
  out.dead_band_min_us = out.dead_band_max_us = b.r.dead_band_us;
  for (const Candidate& c : cands) {
    const bool same = c.replay.SameAs(b.replay);
    if (same && c.r.step_us == b.r.step_us && c.r.phase_us == b.r.phase_us) {
      out.dead_band_min_us = std::min(out.dead_band_min_us, c.r.dead_band_us);
      out.dead_band_max_us = std::max(out.dead_band_max_us, c.r.dead_band_us);
    }
    if (!same && !(c.fit.rms >= out.runner_up_rms_px)) {
      out.runner_up_rms_px = c.fit.rms;
      out.runner_up = Name(c.r);
    }
  }
  out.dead_band_determined = out.dead_band_min_us == out.dead_band_max_us;
  const double px_per_us = std::abs(out.px_per_us);
  if (px_per_us < 4 * out.rms_px || px_per_us < 0.05) {
    out.message = "the image moved " + std::to_string(px_per_us) + " px per us against a residual of " +
                  std::to_string(out.rms_px) + " px: too little motion to resolve 1 us";
    return out;
  }
  out.determined = !std::isfinite(out.runner_up_rms_px) ||
                   (out.runner_up_rms_px >= o.min_rms_ratio * out.rms_px && out.runner_up_rms_px >= out.rms_px + 0.3);
  out.message = DescribeResolution(out) + " (RMS " + std::to_string(out.rms_px) + " px; next best " +
                (out.runner_up.empty() ? std::string("none") : out.runner_up) + ", RMS " +
                std::to_string(out.runner_up_rms_px) + " px)" + (out.determined ? "" : ": not clearly determined");
  return out;
}

}  // namespace owlcal::fitting
