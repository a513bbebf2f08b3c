#include "fitting/vergence_log_fit.h"

#include "calib/csv.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include <ceres/ceres.h>

#include "fitting/format.h"
#include "fitting/observability.h"
#include "models/statistics.h"
#include "models/units.h"
#include "models/vergence.h"

namespace owlcal::fitting {
namespace {

// Residual of one row: predicted minus logged PWM for both eyes, whitened.
struct VergenceRowResidual {
  double distance_m, rx_us, lx_us, sigma_us;
  template <typename T>
  bool operator()(const T* rx, const T* lx, const T* ipd, const T* datum, const T* bearing, T* r) const {
    const T rho = T(distance_m) + datum[0];
    if (rho <= T(0)) return false;
    const T x = rho * ceres::sin(bearing[0]);
    const T z = rho * ceres::cos(bearing[0]);
    const T half = ipd[0] / T(2);
    const T theta_l = ceres::atan2(x + half, z);
    const T theta_r = ceres::atan2(half - x, z);
    const T lx_pred = lx[0] + lx[1] * theta_l * T(kRadToDeg);
    const T rx_pred = rx[0] - rx[1] * theta_r * T(kRadToDeg);
    r[0] = (rx_pred - T(rx_us)) / T(sigma_us);
    r[1] = (lx_pred - T(lx_us)) / T(sigma_us);
    return true;
  }
};

struct SolveOutput {
  VergenceMaps maps;
  std::vector<int> runs;
  ceres::Solver::Summary summary;
  bool covariance_ok = false;
  // sigma (unscaled, i.e. in units of the prior) per determined parameter; the others with why
  std::map<std::string, double> sigma;
  std::map<std::string, std::string> undetermined;
  // sigma of `name`, or infinity when it has none.
  double SigmaOrInfinity(const std::string& name) const {
    const auto it = sigma.find(name);
    return covariance_ok && it != sigma.end() ? it->second : std::numeric_limits<double>::infinity();
  }
  double chi2 = 0;
  int dof = 0;
};

// Index of each run id in order of first appearance.
std::map<int, int> RunIndex(const std::vector<VergenceLogRow>& rows) {
  std::map<int, int> index;
  for (const auto& r : rows) index.emplace(r.run, static_cast<int>(index.size()));
  return index;
}

SolveOutput Solve(const std::vector<VergenceLogRow>& rows,
                  const VergenceFitOptions& o,
                  bool ipd_free,
                  bool datum_free,
                  bool want_covariance) {
  SolveOutput out;
  const std::map<int, int> run_index = RunIndex(rows);
  out.runs.resize(run_index.size());
  for (const auto& [run, k] : run_index) out.runs[k] = run;
  double rx[2] = {o.initial.rx_centre_us, o.initial.rx_us_per_deg};
  double lx[2] = {o.initial.lx_centre_us, o.initial.lx_us_per_deg};
  double ipd = o.ipd_m;
  double datum = o.datum_offset_m;
  std::vector<double> bearing(out.runs.size(), 0.0);

  ceres::Problem problem;
  for (const auto& row : rows) {
    const int k = run_index.at(row.run);
    auto* cost = new ceres::AutoDiffCostFunction<VergenceRowResidual, 2, 2, 2, 1, 1, 1>(
        new VergenceRowResidual{row.true_distance_m, row.rx_us, row.lx_us, o.pwm_sigma_us});
    problem.AddResidualBlock(cost, nullptr, rx, lx, &ipd, &datum, &bearing[k]);
  }
  if (!ipd_free) problem.SetParameterBlockConstant(&ipd);
  if (!datum_free) {
    problem.SetParameterBlockConstant(&datum);
  } else {
    problem.SetParameterLowerBound(&datum, 0, -0.2);
    problem.SetParameterUpperBound(&datum, 0, 0.5);
  }
  for (size_t k = 0; k < bearing.size(); ++k) {
    if (k == 0 || !o.per_run_bearing) problem.SetParameterBlockConstant(&bearing[k]);
  }
  if (ipd_free) {
    problem.SetParameterLowerBound(&ipd, 0, 0.02);
    problem.SetParameterUpperBound(&ipd, 0, 0.2);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = 1e-12;
  so.parameter_tolerance = 1e-12;
  ceres::Solve(so, &problem, &out.summary);

  out.maps.rx_centre_us = rx[0];
  out.maps.rx_us_per_deg = rx[1];
  out.maps.lx_centre_us = lx[0];
  out.maps.lx_us_per_deg = lx[1];
  out.maps.ipd_m = ipd;
  out.maps.datum_offset_m = datum;
  out.maps.run_bearing_rad = bearing;
  out.chi2 = 2 * out.summary.final_cost;
  out.dof = problem.NumResiduals() - problem.NumParameters();
  for (size_t k = 0; k < bearing.size(); ++k)
    if (problem.IsParameterBlockConstant(&bearing[k])) ++out.dof;
  if (!ipd_free) ++out.dof;
  if (!datum_free) ++out.dof;

  // No covariance after a failed solve: it would describe a point that is not a minimum (and
  // Ceres evaluates the Jacobian there, which may not even be defined).
  if (!want_covariance || out.summary.termination_type != ceres::CONVERGENCE) return out;
  // Observability and covariance by the one rule of fitting/observability.h (no local blocks):
  // a direction the data cannot see is "not determined", never a pseudo-inverse's tiny sigma.
  std::vector<double*> globals = {rx, lx};
  std::vector<std::string> names = {"rx.centre", "rx.scale", "lx.centre", "lx.scale"};
  if (ipd_free) {
    globals.push_back(&ipd);
    names.push_back("ipd");
  }
  if (datum_free) {
    globals.push_back(&datum);
    names.push_back("datum");
  }
  for (size_t k = 0; k < bearing.size(); ++k) {
    if (problem.IsParameterBlockConstant(&bearing[k])) continue;
    globals.push_back(&bearing[k]);
    names.push_back("bearing" + std::to_string(k));
  }
  const Observability obs = AnalyseObservability(&problem, globals, {}, names, kDefaultRankTolerance);
  out.covariance_ok = obs.ok;
  if (!obs.ok) return out;
  for (size_t i = 0; i < names.size(); ++i) {
    if (obs.determined[i]) {
      out.sigma[names[i]] = std::sqrt(obs.covariance(i, i));
    } else {
      out.undetermined[names[i]] = obs.reasons[i];
    }
  }
  return out;
}

// The eyes whose us/deg scale the log cannot tell from 0, by key ("rx.scale", "lx.scale"), each with
// why: an eye whose PWM is the same in every row (it fits scale 0 exactly, with a sigma from the
// prior alone), or a scale within 3 sigma of 0. Such a scale is no map, whatever its sigma.
std::map<std::string, std::string> ScalesWithoutSignal(const std::vector<VergenceLogRow>& rows,
                                                       const VergenceMaps& maps,
                                                       double rx_sigma,
                                                       double lx_sigma) {
  std::map<std::string, std::string> out;
  auto check =
      [&](const std::string& key, const std::string& eye, double VergenceLogRow::*pwm, double scale, double sigma) {
        const auto [lo, hi] = std::minmax_element(
            rows.begin(), rows.end(), [&](const auto& a, const auto& b) { return a.*pwm < b.*pwm; });
        if ((*lo).*pwm == (*hi).*pwm) {
          out[key] = eye + " PWM is " + FixedOrDash((*lo).*pwm, 1) +
                     " us in every row: the log holds no vergence of that " +
                     "eye, so its us/deg scale is not a map (log the eye converging on each target)";
        } else if (std::isfinite(sigma) && !(std::abs(scale) > 3 * sigma)) {
          out[key] = eye + " us/deg = " + FixedOrDash(scale, 3) + " +- " + FixedOrDash(sigma, 3) +
                     " cannot be told from 0: its PWM does not follow the distance";
        }
      };
  check("rx.scale", "Rx", &VergenceLogRow::rx_us, maps.rx_us_per_deg, rx_sigma);
  check("lx.scale", "Lx", &VergenceLogRow::lx_us, maps.lx_us_per_deg, lx_sigma);
  return out;
}

using models::Median;

}  // namespace

std::vector<VergenceLogRow> ReadVergenceLogCsv(const std::string& path,
                                               const VergenceColumnRequest& request,
                                               VergenceColumns* used) {
  const calib::CsvTable t = calib::CsvTable::Read(path, {.trim = true});
  const VergenceColumns cols = ResolveVergenceColumns(t.Header(), request, path);
  if (used) *used = cols;
  std::vector<VergenceLogRow> rows;
  for (size_t r = 0; r < t.NumRows(); ++r) {
    VergenceLogRow row;
    row.run = cols.run >= 0 ? t.Int(r, cols.run_name, 0, 1000000) : 1;
    // A true distance is a positive length (up to 1 km); pulse widths are four-digit microseconds.
    row.true_distance_m = t.PositiveNumber(r, cols.distance_name, 1e3 / cols.distance_scale_m) * cols.distance_scale_m;
    row.rx_us = t.Number(r, cols.rx_name, 0, 9999);
    row.lx_us = t.Number(r, cols.lx_name, 0, 9999);
    rows.push_back(row);
  }
  return rows;
}

FixedConstantVergence FixedConstantVergence::FromRobot(const models::RobotConfig& robot,
                                                       double datum_offset_m,
                                                       const std::string& source) {
  FixedConstantVergence f;
  const auto& rx = robot.servos[models::kRx];
  const auto& lx = robot.servos[models::kLx];
  f.rx_centre_us = rx.centre_us;
  f.lx_centre_us = lx.centre_us;
  f.rx_us_per_deg = 1.0 / rx.nominal_deg_per_us;
  f.lx_us_per_deg = 1.0 / lx.nominal_deg_per_us;
  f.rx_direction = rx.direction;
  f.lx_direction = lx.direction;
  f.ipd_m = robot.ipd_m;
  f.datum_offset_m = datum_offset_m;
  f.source = source;
  return f;
}

std::optional<double> FixedConstantVergence::Distance(double rx_us, double lx_us) const {
  const double tr = -rx_direction * (rx_us - rx_centre_us) / rx_us_per_deg * kDegToRad;
  const double tl = lx_direction * (lx_us - lx_centre_us) / lx_us_per_deg * kDegToRad;
  if (std::sin(tl + tr) <= 1e-12) return std::nullopt;
  const double ld = models::SineRuleLeftDistance(ipd_m, tl, tr);
  const double sq = ld * ld + ipd_m * ipd_m / 4 - ld * ipd_m * std::sin(tl);
  if (sq < 0) return std::nullopt;
  return std::sqrt(sq) - datum_offset_m;
}

double VergenceMaps::ThetaLeft(double lx_us) const { return (lx_us - lx_centre_us) / lx_us_per_deg * kDegToRad; }
double VergenceMaps::ThetaRight(double rx_us) const { return -(rx_us - rx_centre_us) / rx_us_per_deg * kDegToRad; }

std::optional<double> VergenceMaps::Distance(double rx_us, double lx_us) const {
  const double tl = ThetaLeft(lx_us), tr = ThetaRight(rx_us);
  if (std::sin(tl + tr) <= 1e-12 || tl + tr >= M_PI) return std::nullopt;
  return models::SineRuleFix(ipd_m, tl, tr).range - datum_offset_m;
}

void VergenceMaps::PredictPwm(double distance_m, int run_index, double* rx_us, double* lx_us) const {
  const double phi =
      run_index >= 0 && run_index < static_cast<int>(run_bearing_rad.size()) ? run_bearing_rad[run_index] : 0.0;
  const double rho = distance_m + datum_offset_m;
  const double x = rho * std::sin(phi), z = rho * std::cos(phi);
  *lx_us = lx_centre_us + lx_us_per_deg * std::atan2(x + ipd_m / 2, z) * kRadToDeg;
  *rx_us = rx_centre_us - rx_us_per_deg * std::atan2(ipd_m / 2 - x, z) * kRadToDeg;
}

bool VergenceFitOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(pwm_sigma_us > 0)) return fail("pwm_sigma_us = " + std::to_string(pwm_sigma_us) + " must be > 0");
  if (!(ipd_m > 0.02 && ipd_m < 0.2)) return fail("ipd_m = " + std::to_string(ipd_m) + " outside 0.02-0.2 m");
  if (!(ipd_sigma_threshold_m > 0)) return fail("ipd_sigma_threshold_m must be > 0");
  if (!(initial.rx_us_per_deg > 0 && initial.lx_us_per_deg > 0)) return fail("initial us_per_deg must be > 0");
  if (max_iterations < 1) return fail("max_iterations = " + std::to_string(max_iterations) + " must be >= 1");
  return true;
}

namespace {

// The log's rows checked (at least 4, at most kMaxVergenceRuns runs, positive distances, finite
// values; throws std::invalid_argument); the distances, sorted, with the number of distinct ones.
std::vector<double> CheckVergenceRows(const std::vector<VergenceLogRow>& rows, size_t* num_distances) {
  if (rows.size() < 4)
    throw std::invalid_argument("vergence log has " + std::to_string(rows.size()) + " rows; need >= 4");
  if (const size_t runs = RunIndex(rows).size(); runs > kMaxVergenceRuns)
    throw std::invalid_argument("vergence log has " + std::to_string(runs) + " runs (distinct run ids); at most " +
                                std::to_string(kMaxVergenceRuns) +
                                " are fitted, each with its own bearing: check the run column");
  std::vector<double> distances;
  for (size_t i = 0; i < rows.size(); ++i) {
    const VergenceLogRow& r = rows[i];
    if (!(std::isfinite(r.true_distance_m) && r.true_distance_m > 0) || !std::isfinite(r.rx_us) ||
        !std::isfinite(r.lx_us))
      throw std::invalid_argument("vergence log row " + std::to_string(i) + ": distance " +
                                  FixedOrDash(r.true_distance_m, 4) + " m, Rx " + FixedOrDash(r.rx_us, 1) + ", Lx " +
                                  FixedOrDash(r.lx_us, 1) + ": distances must be positive and every value finite");
    distances.push_back(r.true_distance_m);
  }
  std::sort(distances.begin(), distances.end());
  *num_distances = std::unique(distances.begin(), distances.end()) - distances.begin();
  return distances;
}

// The final solve and which of the IPD and the datum it let float.
struct VergenceFreeChoice {
  SolveOutput solve;
  bool ipd_free = false;
  bool datum_free = false;
};

// IPD fixed first: it trades against both scales, and a free start can slide into the
// degenerate valley. Then, if asked, freed from that solution and kept only when the data pin
// it (not on a bound, sigma below the threshold) or the user forces it; the datum likewise.
// Why a parameter stayed fixed goes to notes.
VergenceFreeChoice ChooseVergenceFreeParameters(const std::vector<VergenceLogRow>& rows,
                                                const VergenceFitOptions& options,
                                                std::vector<std::string>* notes) {
  VergenceFreeChoice c;
  c.datum_free = options.fit_datum;
  SolveOutput& s = c.solve;
  s = Solve(rows, options, false, c.datum_free, true);
  if (options.ipd_mode != IpdMode::kFixed) {
    VergenceFitOptions o2 = options;
    o2.initial = s.maps;
    o2.datum_offset_m = s.maps.datum_offset_m;
    SolveOutput f = Solve(rows, o2, true, c.datum_free, true);
    const double scale = std::max(1.0, std::sqrt(f.chi2 / std::max(1, f.dof)));
    const double sig = f.SigmaOrInfinity("ipd") * scale;
    const bool on_bound = f.maps.ipd_m < 0.021 || f.maps.ipd_m > 0.199;
    // Freeing IPD must also lower chi2 by more than 9 (3 sigma, in units of the residual
    // variance): in the valley the local covariance can look tight while chi2 is flat.
    const double gain = (s.chi2 - f.chi2) / std::max(1.0, f.chi2 / std::max(1, f.dof));
    if (options.ipd_mode == IpdMode::kFree || (!on_bound && sig < options.ipd_sigma_threshold_m && gain > 9)) {
      s = f;
      c.ipd_free = true;
    } else {
      notes->push_back("IPD not determined by this log (free, it went to " + FixedOrDash(f.maps.ipd_m * 1000, 1) +
                       " mm, lowering chi2 by only " + FixedOrDash(gain, 1) + " residual variances" +
                       "; it trades against the us/deg scales); fixed at " + FixedOrDash(options.ipd_m * 1000, 1) +
                       " mm, so the scales are relative to that IPD");
    }
  }
  if (c.datum_free) {
    const double sig = s.SigmaOrInfinity("datum") * std::max(1.0, std::sqrt(s.chi2 / std::max(1, s.dof)));
    if (!(sig < options.datum_sigma_threshold_m)) {
      notes->push_back("distance datum not determined (sigma " + FixedOrDash(sig * 1000, 0) + " mm); fixed at " +
                       FixedOrDash(options.datum_offset_m * 1000, 0) + " mm in front of the eye centres");
      c.datum_free = false;
      s = Solve(rows, options, c.ipd_free, c.datum_free, true);
    }
  } else {
    notes->push_back("distance datum fixed at " + FixedOrDash(options.datum_offset_m * 1000, 0) + " mm by option");
  }
  return c;
}

// The fitted parameters with their sigmas (scaled by the residual) into fit->parameters, each
// determined by the observability rule, else with the rule's reason; nothing is determined by a
// solve that did not converge or by one distance. True when both maps are determined.
bool AddVergenceParameters(const std::vector<VergenceLogRow>& rows,
                           const VergenceFitOptions& options,
                           const VergenceFreeChoice& choice,
                           size_t num_distances,
                           VergenceLogFit* fit) {
  const SolveOutput& s = choice.solve;
  const bool ipd_free = choice.ipd_free, datum_free = choice.datum_free;
  const double scale = std::max(1.0, std::sqrt(s.chi2 / std::max(1, s.dof)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  auto sig = [&](const std::string& k, double unit) {
    return s.covariance_ok && s.sigma.count(k) ? s.sigma.at(k) * scale * unit : nan;
  };
  auto add =
      [&](const std::string& name, double v, double sigma, const std::string& unit, bool det, const std::string& note) {
        Parameter p;
        p.name = name;
        p.value = v;
        p.sigma = det ? sigma : nan;  // a parameter that is not determined has no sigma
        p.unit = unit;
        p.determined = det;
        p.note = note;
        fit->parameters.push_back(p);
      };
  const bool converged = s.summary.termination_type == ceres::CONVERGENCE;
  const std::string blocked = !converged          ? "solver did not converge"
                              : num_distances < 2 ? "not determined: one distance only"
                              : !s.covariance_ok  ? "not determined: the covariance failed"
                                                  : "";
  const std::map<std::string, std::string> no_signal =
      ScalesWithoutSignal(rows, s.maps, sig("rx.scale", 1), sig("lx.scale", 1));
  for (const auto& [k, why] : no_signal) fit->notes.push_back(why);
  auto det = [&](const std::string& k) { return blocked.empty() && s.sigma.count(k) > 0 && !no_signal.count(k); };
  auto note_of = [&](const std::string& k, const std::string& note) {
    if (!blocked.empty()) return blocked;
    if (const auto it = no_signal.find(k); it != no_signal.end()) return "not determined: " + it->second;
    const auto it = s.undetermined.find(k);
    return it != s.undetermined.end() ? "not determined: " + it->second : note;
  };
  add("servo.Rx.centre_us", s.maps.rx_centre_us, sig("rx.centre", 1), "us", det("rx.centre"), note_of("rx.centre", ""));
  add("servo.Rx.us_per_deg",
      s.maps.rx_us_per_deg,
      sig("rx.scale", 1),
      "us/deg",
      det("rx.scale"),
      note_of("rx.scale", ""));
  add("servo.Lx.centre_us", s.maps.lx_centre_us, sig("lx.centre", 1), "us", det("lx.centre"), note_of("lx.centre", ""));
  add("servo.Lx.us_per_deg",
      s.maps.lx_us_per_deg,
      sig("lx.scale", 1),
      "us/deg",
      det("lx.scale"),
      note_of("lx.scale", ""));
  add("head.ipd_mm",
      s.maps.ipd_m * 1000,
      ipd_free ? sig("ipd", 1000) : nan,
      "mm",
      ipd_free && det("ipd"),
      ipd_free ? note_of("ipd", "") : "fixed: not determined by a vergence log");
  add("vergence.datum_mm",
      s.maps.datum_offset_m * 1000,
      datum_free ? sig("datum", 1000) : nan,
      "mm",
      datum_free && det("datum"),
      datum_free ? note_of("datum", "eye-centre baseline to the distance datum") : "fixed");
  for (size_t k = 1; k < s.runs.size() && options.per_run_bearing; ++k) {
    const std::string b = "bearing" + std::to_string(k);
    add("vergence.run" + std::to_string(s.runs[k]) + ".bearing_deg",
        s.maps.run_bearing_rad[k] * kRadToDeg,
        sig(b, kRadToDeg),
        "deg",
        det(b),
        note_of(b, "relative to run " + std::to_string(s.runs[0])));
  }
  return s.covariance_ok && det("rx.centre") && det("rx.scale") && det("lx.centre") && det("lx.scale");
}

// Each row's whitened residuals and the range change per us of command at its PWM.
std::vector<VergenceRowDiagnostic> VergenceRowDiagnostics(const std::vector<VergenceLogRow>& rows,
                                                          const VergenceFitOptions& options,
                                                          const SolveOutput& s) {
  std::vector<VergenceRowDiagnostic> out;
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& row = rows[i];
    const int k = static_cast<int>(std::find(s.runs.begin(), s.runs.end(), row.run) - s.runs.begin());
    double rx, lx;
    s.maps.PredictPwm(row.true_distance_m, k, &rx, &lx);
    VergenceRowDiagnostic d;
    d.row = static_cast<int>(i);
    d.residual_rx = (rx - row.rx_us) / options.pwm_sigma_us;
    d.residual_lx = (lx - row.lx_us) / options.pwm_sigma_us;
    d.chi2 = d.residual_rx * d.residual_rx + d.residual_lx * d.residual_lx;
    const auto a = s.maps.Distance(row.rx_us + 0.5, row.lx_us), b = s.maps.Distance(row.rx_us - 0.5, row.lx_us);
    const auto c = s.maps.Distance(row.rx_us, row.lx_us + 0.5), e = s.maps.Distance(row.rx_us, row.lx_us - 0.5);
    d.range_per_us_m = (a && b && c && e) ? std::hypot(*a - *b, *c - *e) : std::numeric_limits<double>::infinity();
    out.push_back(d);
  }
  return out;
}

}  // namespace

VergenceLogFit FitVergenceLog(const std::vector<VergenceLogRow>& rows, const VergenceFitOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("VergenceFitOptions: " + why);
  size_t num_distances = 0;
  const std::vector<double> distances = CheckVergenceRows(rows, &num_distances);
  const auto t0 = std::chrono::steady_clock::now();
  VergenceLogFit fit;
  if (num_distances < 2) {
    // Each eye's Rx = centre - scale * angle(D): one distance gives one equation per eye for two
    // unknowns, however many rows repeat it.
    fit.notes.push_back("all " + std::to_string(rows.size()) + " rows are at one distance (" +
                        FixedOrDash(distances[0] * 100, 1) +
                        " cm): a centre and a us/deg scale cannot both be determined "
                        "from one distance; log at least two (better five or more, near and far)");
  }
  const VergenceFreeChoice choice = ChooseVergenceFreeParameters(rows, options, &fit.notes);
  const SolveOutput& s = choice.solve;
  if (s.runs.size() > 1 && options.per_run_bearing)
    fit.notes.push_back("one target-line bearing per run (run " + std::to_string(s.runs[0]) +
                        " fixed at 0): centres are parallel gaze along run " + std::to_string(s.runs[0]) + "'s line");
  fit.maps = s.maps;
  fit.runs = s.runs;
  fit.ipd_free = choice.ipd_free;
  fit.datum_free = choice.datum_free;
  fit.residual_sigma_us = std::sqrt(s.chi2 / std::max(1, s.dof)) * options.pwm_sigma_us;
  const bool ok = AddVergenceParameters(rows, options, choice, num_distances, &fit);
  const bool converged = s.summary.termination_type == ceres::CONVERGENCE;
  fit.summary.problem = "vergence_log";
  fit.summary.termination = ceres::TerminationTypeToString(s.summary.termination_type);
  fit.summary.message = s.summary.message;
  fit.summary.initial_cost = s.summary.initial_cost;
  fit.summary.final_cost = s.summary.final_cost;
  fit.summary.iterations = static_cast<int>(s.summary.iterations.size());
  fit.summary.num_residuals = s.summary.num_residuals;
  fit.summary.rms_px = fit.residual_sigma_us;  // in us here
  // NO_CONVERGENCE is "usable" to Ceres, but its values are not a fit: refuse them too.
  fit.summary.usable = converged && ok;
  fit.summary.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fit.rows = VergenceRowDiagnostics(rows, options, s);
  return fit;
}

namespace {

LooSummary LeaveOneOutImpl(const std::vector<VergenceLogRow>& rows,
                           const VergenceFitOptions& options,
                           const VergenceLogFit& full,
                           const FixedConstantVergence* fixed) {
  LooSummary out;
  out.has_fixed = fixed != nullptr;
  if (fixed) out.fixed_source = fixed->source;
  // Row i is in fold i % folds: one row per fold up to kMaxVergenceFolds rows, so the cost is at
  // most kMaxVergenceFolds refits of the other rows, linear in the rows.
  const size_t folds = std::min(rows.size(), kMaxVergenceFolds);
  out.folds = static_cast<int>(folds);
  out.rows.resize(rows.size());
  for (size_t f = 0; f < folds; ++f) {
    std::vector<VergenceLogRow> rest;
    rest.reserve(rows.size());
    for (size_t j = 0; j < rows.size(); ++j)
      if (j % folds != f) rest.push_back(rows[j]);
    VergenceFitOptions o = options;
    o.initial = full.maps;
    o.ipd_m = full.maps.ipd_m;
    o.datum_offset_m = full.maps.datum_offset_m;
    const SolveOutput s = Solve(rest, o, full.ipd_free, full.datum_free, false);
    for (size_t i = f; i < rows.size(); i += folds) {
      LooRow& r = out.rows[i];
      r.row = static_cast<int>(i);
      r.true_m = rows[i].true_distance_m;
      if (fixed) r.fixed_m = fixed->Distance(rows[i].rx_us, rows[i].lx_us);
      r.loo_m = s.maps.Distance(rows[i].rx_us, rows[i].lx_us);
    }
  }
  std::vector<double> fe, le;
  for (const LooRow& r : out.rows) {
    auto rel = [&](const std::optional<double>& v, int* fails) {
      if (!v || *v <= 0) {
        ++*fails;
        return 1.0;
      }
      return std::min(1.0, std::abs(*v - r.true_m) / r.true_m);
    };
    if (fixed) fe.push_back(rel(r.fixed_m, &out.fixed_failures));
    le.push_back(rel(r.loo_m, &out.loo_failures));
  }
  auto mean = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x;
    return v.empty() ? 0.0 : s / v.size();
  };
  out.fixed_mean_abs_rel = mean(fe);
  out.loo_mean_abs_rel = mean(le);
  out.fixed_median_abs_rel = Median(fe);
  out.loo_median_abs_rel = Median(le);
  return out;
}

}  // namespace

LooSummary LeaveOneOut(const std::vector<VergenceLogRow>& rows,
                       const VergenceFitOptions& options,
                       const VergenceLogFit& full,
                       const FixedConstantVergence& fixed) {
  return LeaveOneOutImpl(rows, options, full, &fixed);
}

LooSummary LeaveOneOut(const std::vector<VergenceLogRow>& rows,
                       const VergenceFitOptions& options,
                       const VergenceLogFit& full) {
  return LeaveOneOutImpl(rows, options, full, nullptr);
}

}  // namespace owlcal::fitting
