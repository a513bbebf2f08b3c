#pragma once
// Monte-Carlo check of reported uncertainties ("honest sigma"): run a fit on
// many noisy realisations with known truth and count how often |estimate - truth| lies
// within 1 and 3 reported sigmas. For Gaussian errors and honest sigmas: 68.3 % and 99.7 %.
//
// Usage:
//   SigmaCoverage cov = RunMonteCarlo(50, /*first_seed=*/1, [&](uint64_t seed) {
//     ... simulate with seed, fit, SetHeadTruth(...) ...
//     return fit.result.parameters;            // Parameter.truth set on those to score
//   });
//   std::cout << cov.Report();
// Only parameters with determined = true, a finite sigma > 0 and a truth are scored.
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "fitting/result.h"

namespace owlcal::fitting {

class SigmaCoverage {
 public:
  // Scores one fit's parameters. `group_suffix` is appended to each parameter's group and name:
  // the bench scores the fused head fit's parameters as "servo maps (fused)" and so on beside
  // the calibration's own (a call with a suffix is not counted as another fit).
  void Add(const std::vector<Parameter>& parameters, const std::string& group_suffix = "");
  // Records a fit that failed (not scored, counted).
  void AddFailure(const std::string& why);

  int num_fits() const { return num_fits_; }
  int num_failures() const { return static_cast<int>(failures_.size()); }
  int num_scored() const { return total_; }
  // Fraction of scored (fit, parameter) pairs with |error| <= k sigma.
  double FractionWithin(double k) const;
  // Per parameter: number scored, fraction within 1 sigma, RMS of error / sigma.
  struct PerParameter {
    int count = 0;
    int within1 = 0;
    int within3 = 0;
    double sum_z2 = 0;
  };
  const std::map<std::string, PerParameter>& per_parameter() const { return per_; }
  // Per group (ParameterGroup): count and fractions within 1 and 3 sigma, RMS(z).
  struct Group {
    int count = 0;
    int within1 = 0;
    int within2 = 0;
    int within3 = 0;
    double sum_z2 = 0;
    double worst_z = 0;
    std::string worst;  // "robot 7 servo.Rx.centre_us"
  };
  const std::map<std::string, Group>& per_group() const { return groups_; }
  // Label of the next Add() (e.g. "robot 7"), used to name the worst parameter of each group.
  void SetLabel(const std::string& label) { label_ = label; }
  // group | n | within 1, 2, 3 sigma | RMS(z) | worst |z| (and whose), and a verdict per group
  // against 68 +- tol1 % within 1 sigma and >= min3 % within 3 sigma (Markdown).
  std::string GroupTable(double tol1 = 5.0, double min3 = 99.0) const;
  // A table: overall fractions, then every parameter's count, within-1/3 sigma and RMS(z).
  std::string Report() const;

 private:
  int num_fits_ = 0;
  int total_ = 0;
  std::vector<double> abs_z_;
  std::map<std::string, PerParameter> per_;
  std::map<std::string, Group> groups_;
  std::string label_;
  std::vector<std::string> failures_;
};

// The group a result parameter belongs to: "lens" (left.*, right.* and the head fit's refined
// head.<eye>.fx ... k3), "stereo" (stereo.*), "servo maps" (servo.*), "head geometry" (other
// head.*), "servo ends" (servo_end.<servo>.<min|max>: a servo map's angle at an end of its
// configured range, value the error against the truth, truth 0), else "other".
std::string ParameterGroup(const std::string& name);

// Runs fit_one(seed) for seeds first_seed .. first_seed + num_seeds - 1. fit_one returns the
// parameters with truth set, or throws std::runtime_error (counted as a failure).
SigmaCoverage RunMonteCarlo(int num_seeds,
                            uint64_t first_seed,
                            const std::function<std::vector<Parameter>(uint64_t seed)>& fit_one);

}  // namespace owlcal::fitting
