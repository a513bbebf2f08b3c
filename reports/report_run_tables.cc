// The tables of the measurement runs (MakeTables, reports/report.h): vergence ranging and its
// summary, the step-response metrics, the settling model, the calibrated saccade, the P loop's gain
// study and the servo limits.
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "reports/report.h"
#include "reports/report_tables.h"

namespace owlcal::reports::internal {
namespace {

// Where a loop-model number comes from (fitting/settling_model.h): nothing when fitted.
std::string Source(const std::string& source) {
  if (source == "prior") return " (a prior: the steps do not determine it)";
  return source == "fitted" || source.empty() ? "" : " (" + source + ")";
}

}  // namespace

void AppendRangingTables(const ReportData& d, std::vector<Table>* out) {
  if (!d.ranging) return;
  const auto& r = *d.ranging;
  Table t{"ranging",
          "Vergence ranging per fixation (every fixation the protocol tried; only status ok is ranged)",
          {"fixation",
           "status",
           "true [m]",
           "calibrated [m]",
           "error [%]",
           "\u00b12\u03c3 [%]",
           "within \u00b12\u03c3",
           "ray gap [mm]",
           "course nominal [m]",
           "nominal error [%]",
           "reason"},
          {}};
  for (const auto& x : r.rows)
    t.rows.push_back({std::to_string(x.index),
                      calib::TrialStatusName(x.status),
                      Fmt(x.true_m, 4),
                      x.ok ? Fmt(x.range_m, 5) : "not ranged",
                      x.ok ? Pct(x.rel_error) : "",
                      x.ok ? Pct(2 * x.sigma_m / x.true_m) : "",
                      x.ok ? Bool(std::abs(x.error_m) <= 2 * x.sigma_m) : "",
                      std::isfinite(x.gap_m) ? Fmt(1000 * x.gap_m, 3) : "",
                      x.ok ? (x.nominal_m ? Fmt(*x.nominal_m, 4) : "none: gaze rays diverge") : "",
                      x.ok && x.nominal_m ? Pct(x.nominal_rel_error) : "",
                      x.reason});
  out->push_back(t);
  // Robust summary: the median and the count of failures, not an RMS one outlier dominates.
  std::vector<double> cal, nom;
  int within = 0, nominal_none = 0;
  std::map<std::string, int> by_status;
  for (const auto& x : r.rows) {
    if (x.ok) {
      cal.push_back(std::abs(x.rel_error));
      within += std::abs(x.error_m) <= 2 * x.sigma_m;
      if (x.nominal_m)
        nom.push_back(std::abs(x.nominal_rel_error));
      else
        ++nominal_none;
    } else {
      ++by_status[calib::TrialStatusName(x.status)];
    }
  }
  auto median = [](std::vector<double> v) -> double {
    if (v.empty()) return NAN;
    std::sort(v.begin(), v.end());
    return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  };
  auto maxv = [](const std::vector<double>& v) -> double {
    return v.empty() ? NAN : *std::max_element(v.begin(), v.end());
  };
  const std::string of_n = " of " + std::to_string(r.rows.size());
  Table s{"ranging_summary", "Vergence ranging summary", {"quantity", "calibrated head", "course nominal method"}, {}};
  s.rows = {{"fixations ok and ranged", std::to_string(cal.size()) + of_n, std::to_string(nom.size()) + of_n}};
  for (const auto& [status, n] : by_status)
    s.rows.push_back({"fixations " + status + " (not ranged; reasons in the table)", std::to_string(n) + of_n, ""});
  s.rows.push_back({"ok but no nominal range", "", std::to_string(nominal_none) + " (gaze rays diverge)"});
  s.rows.push_back({"median |relative error| [%]", Pct(median(cal)), Pct(median(nom))});
  s.rows.push_back({"max |relative error| [%]", Pct(maxv(cal)), Pct(maxv(nom))});
  s.rows.push_back(
      {"within \u00b12\u03c3 of the truth", std::to_string(within) + " of " + std::to_string(cal.size()), ""});
  // What was (not) checked: the size check's reference, sigma without a covariance (the notes
  // per fixation are the table's reasons).
  for (const auto& n : r.notes)
    if (n.rfind("fixation ", 0) != 0) s.rows.push_back({"note", n, ""});
  out->push_back(s);
}

void AppendStepMetricsTable(const ReportData& d, std::vector<Table>* out) {
  if (d.steps.empty()) return;
  int measured = 0, ok = 0;
  for (const auto& s : d.steps)
    if (!s.simulated) {
      ++measured;
      ok += s.status == calib::TrialStatus::kOk;
    }
  Table t{"step_metrics",
          "Step-response metrics (MATLAB stepinfo with y_init = 0, y_final = 1 in fractions of the step); every trial "
          "the protocol tried: " +
              std::to_string(ok) + " ok of " + std::to_string(measured),
          {"gain",
           "step [deg]",
           "trial",
           "rise 10\u201390 % [s]",
           "settling 2 % [s]",
           "overshoot [%]",
           "undershoot [%]",
           "peak [-]",
           "peak time [s]",
           "steady-state error [%]",
           "residual offset [px]",
           "source",
           "status",
           "reason"},
          {}};
  for (const auto& s : d.steps) {
    const std::string source = s.simulated                ? "model"
                               : s.controller == "p-loop" ? "measured"
                                                          : "measured, " + s.controller;
    if (s.t_s.empty()) {
      t.rows.push_back({Fmt(s.gain, 3),
                        Fmt(s.amplitude_deg, 3),
                        std::to_string(s.trial),
                        "",
                        "",
                        "",
                        "",
                        "",
                        "",
                        "",
                        "",
                        source,
                        calib::TrialStatusName(s.status),
                        s.reason});
      continue;
    }
    t.rows.push_back({Fmt(s.gain, 3),
                      Fmt(s.amplitude_deg, 3),
                      std::to_string(s.trial),
                      Fmt(s.info.rise_time, 3),
                      s.info.settled ? Fmt(s.info.settling_time, 3) : "not settled",
                      Fmt(s.info.overshoot_pct, 3),
                      Fmt(s.info.undershoot_pct, 3),
                      Fmt(s.info.peak, 4),
                      Fmt(s.info.peak_time, 3),
                      Pct(SteadyStateError(s), 3),
                      Fmt(s.residual_px, 3),
                      source,
                      calib::TrialStatusName(s.status),
                      s.reason});
  }
  out->push_back(t);
}

void AppendSettlingTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.settling) return;
  const auto& st = *d.settling;
  auto range = [](double med, double lo, double hi) {
    if (!std::isfinite(med)) return std::string("not settled");
    return Fmt(med, 3) + " (" + Fmt(lo, 3) + "\u2013" + Fmt(hi, 3) + ")";
  };
  int agree = 0;
  for (const auto& r : st.rows) agree += r.agreement.rfind("agrees", 0) == 0;
  Table t{"settling_model",
          "Settling: the loop model against the measured trials, per gain and step (" + std::to_string(agree) + " of " +
              std::to_string(st.rows.size()) + " agree). Loop model: slew " +
              Fmt(st.model.slew_us_per_s * st.deg_per_us, 4) + " \u00b0/s" + Source(st.slew_source) + ", lag " +
              Fmt(1000 * st.model.lag_s, 3) + " ms" + Source(st.lag_source) + ", exposure delay " +
              Fmt(1000 * st.model.exposure_delay_s, 3) + " ms (fitted from the step frames), latency " +
              Fmt(st.latency_ms, 4) + " ms, backlash " + Fmt(st.model.hysteresis_us, 3) +
              " \u00b5s; course model: " + "ideal P loop with d = " + std::to_string(st.ideal_delay_frames) + " frames",
          {"gain",
           "step [deg]",
           "band [%]",
           "trials run of N",
           "measured [s] median (min\u2013max)",
           "loop model [s] median (range)",
           "course model [s]",
           "agreement",
           "why"},
          {}};
  for (const auto& r : st.rows)
    t.rows.push_back(
        {Fmt(r.gain, 3),
         Fmt(r.amplitude_deg, 3),
         Fmt(100 * r.band, 3),
         std::to_string(r.num_ok) + " of " + std::to_string(r.num_trials),
         r.num_ok
             ? range(r.measured_median_s, r.measured_lo_s, r.measured_hi_s) +
                   (r.num_settled < r.num_ok ? ", " + std::to_string(r.num_ok - r.num_settled) + " not settled" : "")
             : "",
         range(r.predicted_median_s, r.predicted_lo_s, r.predicted_hi_s),
         r.ideal_stable ? (std::isfinite(r.ideal_s) ? Fmt(r.ideal_s, 3) : "not settled") : "unstable",
         r.agreement,
         r.why});
  out->push_back(t);
}

void AppendSaccadeTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.saccade) return;
  // The calibrated-map saccade against the physical bound and the P loop.
  const auto& sa = *d.saccade;
  auto ms = [](double s) { return std::isfinite(s) ? Fmt(1000 * s, 4) : std::string("not settled"); };
  Table t{"saccade",
          "Calibrated saccade, " + Fmt(sa.amplitude_deg, 3) +
              " deg steps: one saccade from the calibrated servo maps "
              "and the target's pixel, then latency-aware corrections; 2 % settling against the physical bound (slew "
              "time + exposure-to-arrival latency + one frame) and the course's P loop at K = " +
              Fmt(sa.ploop_gain, 3) + " (same step). " + std::to_string(sa.num_ok) + " ok of " +
              std::to_string(sa.num_trials) + " trials",
          {"controller",
           "trials ok of N",
           "settled",
           "2 % settling [ms] median (min–max)",
           "bound [ms]",
           "ratio to bound",
           "speed-up vs P loop"},
          {}};
  t.rows.push_back(
      {"calibrated saccade",
       std::to_string(sa.num_ok) + " of " + std::to_string(sa.num_trials),
       std::to_string(sa.num_settled),
       std::isfinite(sa.median_s) ? ms(sa.median_s) + " (" + ms(sa.lo_s) + "–" + ms(sa.hi_s) + ")" : "not settled",
       ms(sa.bound_s),
       std::isfinite(sa.ratio_to_bound) ? Fmt(sa.ratio_to_bound, 3) : "",
       std::isfinite(sa.speedup_vs_ploop) ? Fmt(sa.speedup_vs_ploop, 3) : ""});
  t.rows.push_back({"P loop, K = " + Fmt(sa.ploop_gain, 3),
                    std::to_string(sa.ploop_trials) + " ok",
                    std::to_string(sa.ploop_settled),
                    ms(sa.ploop_median_s),
                    ms(sa.bound_s),
                    std::isfinite(sa.ploop_median_s / sa.bound_s) ? Fmt(sa.ploop_median_s / sa.bound_s, 3) : "",
                    "1"});
  for (const auto& n : sa.notes) t.rows.push_back({"note: " + n, "", "", "", "", "", ""});
  out->push_back(t);
}

void AppendGainStudyTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.gains) return;
  const auto& g = *d.gains;
  Table t{"gain_study",
          "Incremental P loop with latency (model): gain limits and the fastest stable gain",
          {"quantity", "value"},
          {}};
  t.rows = {{"delay [frames]", std::to_string(g.delay_frames)},
            {"frame rate [fps]", Fmt(g.fps, 3)},
            {"K_crit = 2 sin(pi / (2 (2d + 1)))", Fmt(g.critical_gain, 4)},
            {"K_mono = d^d / (d + 1)^(d + 1)", Fmt(g.monotone_gain, 4)}};
  if (g.fastest) {
    t.rows.push_back({"fastest stable gain", Fmt(g.fastest->gain, 3)});
    t.rows.push_back({"its 2 % settling [frames]", std::to_string(g.fastest->settling_frames)});
    t.rows.push_back({"its 2 % settling [s]", Fmt(g.fastest->settling_time_s, 3)});
    t.rows.push_back({"its overshoot [%]", Fmt(g.fastest->overshoot_pct, 3)});
  }
  for (size_t i = 0; i < g.amplitudes_deg.size(); ++i)
    t.rows.push_back({"physical lower bound, " + Fmt(g.amplitudes_deg[i], 3) + " deg step [s]",
                      Fmt(g.lower_bound_fast_s[i], 3) + " - " + Fmt(g.lower_bound_slow_s[i], 3)});
  out->push_back(t);
}

void AppendLimitsTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.limits) return;
  Table t{"limits",
          "Servo limits: configured vs measured",
          {"servo",
           "configured min [\u00b5s]",
           "configured max [\u00b5s]",
           "measured min [\u00b5s]",
           "low end",
           "measured max [\u00b5s]",
           "high end",
           "measured range [deg]",
           "recommended min [\u00b5s]",
           "recommended max [\u00b5s]"},
          {}};
  for (const auto& s : d.limits->servos)
    t.rows.push_back({s.name,
                      std::to_string(s.configured_min_us),
                      std::to_string(s.configured_max_us),
                      s.measured_min_us ? Fmt(*s.measured_min_us, 6) : "",
                      s.measured_min_us ? evaluation::LimitCauseName(s.min_cause) : "",
                      s.measured_max_us ? Fmt(*s.measured_max_us, 6) : "",
                      s.measured_max_us ? evaluation::LimitCauseName(s.max_cause) : "",
                      std::isfinite(s.measured_max_deg - s.measured_min_deg)
                          ? Fmt(std::abs(s.measured_max_deg - s.measured_min_deg), 4)
                          : "",
                      std::to_string(s.recommended_min_us),
                      std::to_string(s.recommended_max_us)});
  out->push_back(t);
}

}  // namespace owlcal::reports::internal
