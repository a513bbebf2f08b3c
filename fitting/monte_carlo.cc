#include "fitting/monte_carlo.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace owlcal::fitting {

void SigmaCoverage::Add(const std::vector<Parameter>& parameters) {
  ++num_fits_;
  for (const Parameter& p : parameters) {
    if (!p.determined || !p.truth || !std::isfinite(p.sigma) || !(p.sigma > 0) || !std::isfinite(p.value)) continue;
    const double z = std::abs(p.value - *p.truth) / p.sigma;
    abs_z_.push_back(z);
    ++total_;
    PerParameter& pp = per_[p.name];
    ++pp.count;
    if (z <= 1.0) ++pp.within1;
    if (z <= 3.0) ++pp.within3;
    pp.sum_z2 += z * z;
  }
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
  std::snprintf(line, sizeof(line), "fits %d (failed %d), scored %d: within 1 sigma %.1f %% (68.3), within 3 sigma %.2f %% (99.7)\n",
                num_fits_, num_failures(), total_, 100 * FractionWithin(1), 100 * FractionWithin(3));
  out += line;
  std::snprintf(line, sizeof(line), "%-34s %6s %9s %9s %8s\n", "parameter", "n", "<=1sig %", "<=3sig %", "rms(z)");
  out += line;
  for (const auto& [name, pp] : per_) {
    std::snprintf(line, sizeof(line), "%-34s %6d %9.1f %9.1f %8.2f\n", name.c_str(), pp.count,
                  100.0 * pp.within1 / pp.count, 100.0 * pp.within3 / pp.count, std::sqrt(pp.sum_z2 / pp.count));
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
