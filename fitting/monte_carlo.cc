#include "fitting/monte_carlo.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace owlcal::fitting {

void SigmaCoverage::Add(const std::vector<Parameter>& parameters, const std::string& group_suffix) {
  if (group_suffix.empty()) ++num_fits_;
  for (const Parameter& p : parameters) {
    if (!p.determined || !p.truth || !std::isfinite(p.sigma) || !(p.sigma > 0) || !std::isfinite(p.value)) continue;
    const double z = std::abs(p.value - *p.truth) / p.sigma;
    abs_z_.push_back(z);
    ++total_;
    PerParameter& pp = per_[p.name + group_suffix];
    ++pp.count;
    if (z <= 1.0) ++pp.within1;
    if (z <= 3.0) ++pp.within3;
    pp.sum_z2 += z * z;
    Group& g = groups_[ParameterGroup(p.name) + group_suffix];
    ++g.count;
    if (z <= 1.0) ++g.within1;
    if (z <= 2.0) ++g.within2;
    if (z <= 3.0) ++g.within3;
    g.sum_z2 += z * z;
    if (z > g.worst_z) {
      g.worst_z = z;
      g.worst = (label_.empty() ? "" : label_ + " ") + p.name + group_suffix;
    }
  }
}

std::string ParameterGroup(const std::string& name) {
  auto starts = [&](const char* prefix) { return name.rfind(prefix, 0) == 0; };
  if (starts("left.") || starts("right.")) return "lens";
  if (starts("stereo.")) return "stereo";
  if (starts("servo.")) return "servo maps";
  if (starts("servo_end.")) return "servo ends";
  if (starts("head.")) {
    const std::string last = name.substr(name.rfind('.') + 1);
    static const char* kLens[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
    for (const char* l : kLens)
      if (last == l) return "lens";
    return "head geometry";
  }
  return "other";
}

std::string SigmaCoverage::GroupTable(double tol1, double min3) const {
  std::string out =
      "| group | n | within 1 sigma | within 2 sigma | within 3 sigma | RMS(z) | worst |z| | verdict |\n"
      "|---|---|---|---|---|---|---|---|\n";
  char line[512];
  for (const auto& [name, g] : groups_) {
    const double n = std::max(1, g.count);
    const double f1 = 100.0 * g.within1 / n, f2 = 100.0 * g.within2 / n, f3 = 100.0 * g.within3 / n;
    const bool ok = std::abs(f1 - 68.27) <= tol1 && f3 >= min3;
    std::snprintf(line,
                  sizeof(line),
                  "| %s | %d | %.1f %% | %.1f %% | %.2f %% | %.2f | %.1f (%s) | %s |\n",
                  name.c_str(),
                  g.count,
                  f1,
                  f2,
                  f3,
                  std::sqrt(g.sum_z2 / n),
                  g.worst_z,
                  g.worst.c_str(),
                  ok ? "ok" : "OUT OF TARGET");
    out += line;
  }
  return out;
}

void SigmaCoverage::AddFailure(const std::string& why) {
  ++num_fits_;
  failures_.push_back(why);
}

double SigmaCoverage::FractionWithin(double k) const {
  if (abs_z_.empty()) return std::nan("");
  int n = 0;
  for (double z : abs_z_)
    if (z <= k) ++n;
  return double(n) / double(abs_z_.size());
}

std::string SigmaCoverage::Report() const {
  std::string out;
  char line[256];
  std::snprintf(line,
                sizeof(line),
                "fits %d (failed %d), scored %d: within 1 sigma %.1f %% (68.3), within 3 sigma %.2f %% (99.7)\n",
                num_fits_,
                num_failures(),
                total_,
                100 * FractionWithin(1),
                100 * FractionWithin(3));
  out += line;
  std::snprintf(line, sizeof(line), "%-34s %6s %9s %9s %8s\n", "parameter", "n", "<=1sig %", "<=3sig %", "rms(z)");
  out += line;
  for (const auto& [name, pp] : per_) {
    std::snprintf(line,
                  sizeof(line),
                  "%-34s %6d %9.1f %9.1f %8.2f\n",
                  name.c_str(),
                  pp.count,
                  100.0 * pp.within1 / pp.count,
                  100.0 * pp.within3 / pp.count,
                  std::sqrt(pp.sum_z2 / pp.count));
    out += line;
  }
  for (const std::string& f : failures_) out += "failed: " + f + "\n";
  return out;
}

SigmaCoverage RunMonteCarlo(int num_seeds,
                            uint64_t first_seed,
                            const std::function<std::vector<Parameter>(uint64_t seed)>& fit_one) {
  SigmaCoverage coverage;
  for (int i = 0; i < num_seeds; ++i) {
    const uint64_t seed = first_seed + static_cast<uint64_t>(i);
    try {
      coverage.Add(fit_one(seed));
    } catch (const std::runtime_error& e) {
      coverage.AddFailure("seed " + std::to_string(seed) + ": " + e.what());
    }
  }
  return coverage;
}

}  // namespace owlcal::fitting
