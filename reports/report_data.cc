#include "reports/report_data.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <stdexcept>

#include "fitting/calibration_folder.h"
#include "io/json_strict.h"
#include "models/units.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

using nlohmann::json;

double Get(const json& j, const char* k, double dflt = kNaN) {
  if (!j.contains(k) || j.at(k).is_null()) return dflt;
  return j.at(k).get<double>();
}
json OptNum(const std::optional<double>& v) { return v ? io::JsonNumber(*v) : json(nullptr); }
std::optional<double> GetOpt(const json& j, const char* k) {
  if (!j.contains(k) || j.at(k).is_null()) return std::nullopt;
  return j.at(k).get<double>();
}
std::vector<double> Vec(const json& j, const char* k) {
  std::vector<double> v;
  if (!j.contains(k)) return v;
  for (const json& x : j.at(k)) v.push_back(x.is_null() ? kNaN : x.get<double>());
  return v;
}
json VecJson(const std::vector<double>& v) {
  json a = json::array();
  for (double x : v) a.push_back(io::JsonNumber(x));
  return a;
}

json StepInfoJson(const fitting::StepInfo& s) {
  return {{"y_init", io::JsonNumber(s.y_init)},
          {"y_final", io::JsonNumber(s.y_final)},
          {"rise_time", io::JsonNumber(s.rise_time)},
          {"settling_time", io::JsonNumber(s.settling_time)},
          {"settling_index", s.settling_index},
          {"settled", s.settled},
          {"overshoot_pct", io::JsonNumber(s.overshoot_pct)},
          {"undershoot_pct", io::JsonNumber(s.undershoot_pct)},
          {"peak", io::JsonNumber(s.peak)},
          {"peak_time", io::JsonNumber(s.peak_time)},
          {"steady_state_error", io::JsonNumber(s.steady_state_error)}};
}
fitting::StepInfo StepInfoFromJson(const json& j) {
  fitting::StepInfo s;
  s.y_init = Get(j, "y_init");
  s.y_final = Get(j, "y_final");
  s.rise_time = Get(j, "rise_time");
  s.settling_time = Get(j, "settling_time");
  s.settling_index = j.value("settling_index", -1);
  s.settled = j.value("settled", false);
  s.overshoot_pct = Get(j, "overshoot_pct");
  s.undershoot_pct = Get(j, "undershoot_pct");
  s.peak = Get(j, "peak");
  s.peak_time = Get(j, "peak_time");
  s.steady_state_error = Get(j, "steady_state_error");
  return s;
}

json GainJson(const fitting::GainSettling& g) {
  return {{"gain", g.gain},
          {"stable", g.stable},
          {"settled", g.settled},
          {"settling_frames", g.settling_frames},
          {"overshoot_pct", io::JsonNumber(g.overshoot_pct)},
          {"settling_time_s", io::JsonNumber(g.settling_time_s)}};
}
fitting::GainSettling GainFromJson(const json& j) {
  fitting::GainSettling g;
  g.gain = Get(j, "gain");
  g.stable = j.value("stable", false);
  g.settled = j.value("settled", false);
  g.settling_frames = j.value("settling_frames", -1);
  g.overshoot_pct = Get(j, "overshoot_pct");
  g.settling_time_s = Get(j, "settling_time_s");
  return g;
}

// evaluation.json's "ranging" entries.
void AddRangingJson(const ReportData& d, json* out) {
  json& j = *out;
  if (d.ranging) {
    const auto& r = *d.ranging;
    json rows = json::array();
    for (const auto& x : r.rows)
      rows.push_back({{"index", x.index},
                      {"true_m", x.true_m},
                      {"ok", x.ok},
                      {"status", calib::TrialStatusName(x.status)},
                      {"reason", x.reason},
                      {"range_m", io::JsonNumber(x.range_m)},
                      {"error_m", io::JsonNumber(x.error_m)},
                      {"rel_error", io::JsonNumber(x.rel_error)},
                      {"sigma_m", io::JsonNumber(x.sigma_m)},
                      {"gap_m", io::JsonNumber(x.gap_m)},
                      {"nominal_m", OptNum(x.nominal_m)},
                      {"nominal_rel_error", io::JsonNumber(x.nominal_rel_error)}});
    json theory = json::array();
    for (const auto& t : r.theory)
      theory.push_back({{"distance_m", t.distance_m},
                        {"nominal_1us_rel", io::JsonNumber(t.nominal_1us_rel)},
                        {"nominal_half_px_rel", io::JsonNumber(t.nominal_half_px_rel)},
                        {"calibrated_sigma_rel", io::JsonNumber(t.calibrated_sigma_rel)}});
    j["ranging"] = {{"rows", rows},
                    {"theory", theory},
                    {"num_ok", r.num_ok},
                    {"rms_rel_error", io::JsonNumber(r.rms_rel_error)},
                    {"mean_abs_rel_error", io::JsonNumber(r.mean_abs_rel_error)},
                    {"max_abs_rel_error", io::JsonNumber(r.max_abs_rel_error)},
                    {"fraction_within_2sigma", io::JsonNumber(r.fraction_within_2sigma)},
                    {"nominal_rms_rel_error", io::JsonNumber(r.nominal_rms_rel_error)},
                    {"propagated", r.propagated},
                    {"notes", r.notes}};
  }
}

// evaluation.json's "limits" entries.
void AddLimitsJson(const ReportData& d, json* out) {
  json& j = *out;
  if (d.limits) {
    json servos = json::array();
    for (const auto& s : d.limits->servos)
      servos.push_back({{"servo", s.servo},
                        {"name", s.name},
                        {"configured_min_us", s.configured_min_us},
                        {"configured_max_us", s.configured_max_us},
                        {"configured_centre_us", s.configured_centre_us},
                        {"measured_min_us", OptNum(s.measured_min_us)},
                        {"measured_max_us", OptNum(s.measured_max_us)},
                        {"min_cause", evaluation::LimitCauseName(s.min_cause)},
                        {"max_cause", evaluation::LimitCauseName(s.max_cause)},
                        {"configured_min_deg", io::JsonNumber(s.configured_min_deg)},
                        {"configured_max_deg", io::JsonNumber(s.configured_max_deg)},
                        {"measured_min_deg", io::JsonNumber(s.measured_min_deg)},
                        {"measured_max_deg", io::JsonNumber(s.measured_max_deg)},
                        {"recommended_min_us", s.recommended_min_us},
                        {"recommended_max_us", s.recommended_max_us},
                        {"min_excess_us", io::JsonNumber(s.min_excess_us)},
                        {"max_excess_us", io::JsonNumber(s.max_excess_us)}});
    j["limits"] = {{"servos", servos}, {"notes", d.limits->notes}};
  }
}

// evaluation.json's "gains" entries.
void AddGainsJson(const ReportData& d, json* out) {
  json& j = *out;
  if (d.gains) {
    const auto& g = *d.gains;
    json sim = json::array();
    for (const auto& r : g.simulated) sim.push_back(GainJson(r));
    j["gains"] = {{"delay_frames", g.delay_frames},
                  {"fps", g.fps},
                  {"simulated", sim},
                  {"critical_gain", g.critical_gain},
                  {"monotone_gain", g.monotone_gain},
                  {"fastest", g.fastest ? GainJson(*g.fastest) : json(nullptr)},
                  {"amplitudes_deg", g.amplitudes_deg},
                  {"lower_bound_fast_s", g.lower_bound_fast_s},
                  {"lower_bound_slow_s", g.lower_bound_slow_s}};
  }
}

// evaluation.json's "settling" entries.
void AddSettlingJson(const ReportData& d, json* out) {
  json& j = *out;
  if (d.settling) {
    const auto& st = *d.settling;
    json rows = json::array(), curve = json::array();
    for (const auto& r : st.rows)
      rows.push_back({{"gain", r.gain},
                      {"amplitude_deg", r.amplitude_deg},
                      {"num_trials", r.num_trials},
                      {"num_ok", r.num_ok},
                      {"num_settled", r.num_settled},
                      {"measured_median_s", io::JsonNumber(r.measured_median_s)},
                      {"measured_lo_s", io::JsonNumber(r.measured_lo_s)},
                      {"measured_hi_s", io::JsonNumber(r.measured_hi_s)},
                      {"predicted_settled", r.predicted_settled},
                      {"predicted_runs", r.predicted_runs},
                      {"predicted_median_s", io::JsonNumber(r.predicted_median_s)},
                      {"predicted_lo_s", io::JsonNumber(r.predicted_lo_s)},
                      {"predicted_hi_s", io::JsonNumber(r.predicted_hi_s)},
                      {"ideal_s", io::JsonNumber(r.ideal_s)},
                      {"ideal_stable", r.ideal_stable},
                      {"band", r.band},
                      {"no_servo_dynamics_s", io::JsonNumber(r.no_servo_dynamics_s)},
                      {"no_dead_zone_s", io::JsonNumber(r.no_dead_zone_s)},
                      {"agreement", r.agreement},
                      {"why", r.why}});
    for (const auto& c : st.curve)
      curve.push_back({c.gain,
                       c.amplitude_deg,
                       io::JsonNumber(c.median_s),
                       io::JsonNumber(c.lo_s),
                       io::JsonNumber(c.hi_s),
                       io::JsonNumber(c.ideal_s)});
    j["settling"] = {{"model",
                      {{"fps", st.model.fps},
                       {"exposure_delay_s", st.model.exposure_delay_s},
                       {"slew_us_per_s", st.model.slew_us_per_s},
                       {"lag_s", st.model.lag_s},
                       {"hysteresis_us", st.model.hysteresis_us},
                       {"px_per_us", st.model.px_per_us},
                       {"nominal_px_per_us", st.model.nominal_px_per_us},
                       {"noise_px", st.model.noise_px},
                       {"tolerance_px", st.model.tolerance_px},
                       {"max_step_us", st.model.max_step_us},
                       {"latency_frames", st.model.latency_frames}}},
                     {"slew_source", st.slew_source},
                     {"lag_source", st.lag_source},
                     {"latency_ms", io::JsonNumber(st.latency_ms)},
                     {"ideal_delay_frames", st.ideal_delay_frames},
                     {"deg_per_us", st.deg_per_us},
                     {"servo", st.servo},
                     {"rows", rows},
                     {"curve", curve},
                     {"notes", st.notes}};
  }
}

// evaluation.json's "saccade" entries.
void AddSaccadeJson(const ReportData& d, json* out) {
  json& j = *out;
  if (d.saccade) {
    const auto& sa = *d.saccade;
    j["saccade"] = {{"amplitude_deg", sa.amplitude_deg},
                    {"slew_deg_per_s", io::JsonNumber(sa.slew_deg_per_s)},
                    {"exposure_delay_s", io::JsonNumber(sa.exposure_delay_s)},
                    {"fps", sa.fps},
                    {"bound_s", io::JsonNumber(sa.bound_s)},
                    {"num_trials", sa.num_trials},
                    {"num_ok", sa.num_ok},
                    {"num_settled", sa.num_settled},
                    {"median_s", io::JsonNumber(sa.median_s)},
                    {"lo_s", io::JsonNumber(sa.lo_s)},
                    {"hi_s", io::JsonNumber(sa.hi_s)},
                    {"ratio_to_bound", io::JsonNumber(sa.ratio_to_bound)},
                    {"ploop_gain", sa.ploop_gain},
                    {"ploop_trials", sa.ploop_trials},
                    {"ploop_settled", sa.ploop_settled},
                    {"ploop_median_s", io::JsonNumber(sa.ploop_median_s)},
                    {"speedup_vs_ploop", io::JsonNumber(sa.speedup_vs_ploop)},
                    {"notes", sa.notes}};
  }
}

// The "ranging" entries of evaluation.json, when present.
void ReadRangingJson(const json& j, ReportData* d) {
  if (j.contains("ranging")) {
    const json& r = j.at("ranging");
    evaluation::RangingEvaluation ev;
    for (const json& x : r.at("rows")) {
      evaluation::RangingRow row;
      row.index = x.value("index", 0);
      row.true_m = Get(x, "true_m");
      row.ok = x.value("ok", false);
      const std::string status = x.value("status", row.ok ? "ok" : "failed");
      const auto st = calib::TrialStatusFromName(status);
      if (!st)
        throw std::runtime_error("evaluation.json: ranging row " + std::to_string(row.index) + ": unknown status '" +
                                 status + "'");
      row.status = *st;
      row.reason = x.value("reason", std::string());
      row.range_m = Get(x, "range_m");
      row.error_m = Get(x, "error_m");
      row.rel_error = Get(x, "rel_error");
      row.sigma_m = Get(x, "sigma_m");
      row.gap_m = Get(x, "gap_m");
      row.nominal_m = GetOpt(x, "nominal_m");
      row.nominal_rel_error = Get(x, "nominal_rel_error");
      ev.rows.push_back(row);
    }
    for (const json& x : r.at("theory")) {
      evaluation::RangingTheoryRow t;
      t.distance_m = Get(x, "distance_m");
      t.nominal_1us_rel = Get(x, "nominal_1us_rel");
      t.nominal_half_px_rel = Get(x, "nominal_half_px_rel");
      t.calibrated_sigma_rel = Get(x, "calibrated_sigma_rel");
      ev.theory.push_back(t);
    }
    ev.num_ok = r.value("num_ok", 0);
    ev.rms_rel_error = Get(r, "rms_rel_error");
    ev.mean_abs_rel_error = Get(r, "mean_abs_rel_error");
    ev.max_abs_rel_error = Get(r, "max_abs_rel_error");
    ev.fraction_within_2sigma = Get(r, "fraction_within_2sigma");
    ev.nominal_rms_rel_error = Get(r, "nominal_rms_rel_error");
    ev.propagated = r.value("propagated", std::vector<std::string>{});
    ev.notes = r.value("notes", std::vector<std::string>{});
    d->ranging = ev;
  }
}

// The "limits" entries of evaluation.json, when present.
void ReadLimitsJson(const json& j, ReportData* d) {
  if (j.contains("limits")) {
    evaluation::LimitsEvaluation ev;
    for (const json& s : j.at("limits").at("servos")) {
      evaluation::ServoLimits l;
      l.servo = s.at("servo").get<int>();
      l.name = s.value("name", "");
      l.configured_min_us = s.at("configured_min_us").get<int>();
      l.configured_max_us = s.at("configured_max_us").get<int>();
      l.configured_centre_us = s.value("configured_centre_us", 0);
      l.measured_min_us = GetOpt(s, "measured_min_us");
      l.measured_max_us = GetOpt(s, "measured_max_us");
      l.min_cause = evaluation::LimitCauseFromName(s.value("min_cause", ""));
      l.max_cause = evaluation::LimitCauseFromName(s.value("max_cause", ""));
      l.configured_min_deg = Get(s, "configured_min_deg");
      l.configured_max_deg = Get(s, "configured_max_deg");
      l.measured_min_deg = Get(s, "measured_min_deg");
      l.measured_max_deg = Get(s, "measured_max_deg");
      l.recommended_min_us = s.value("recommended_min_us", l.configured_min_us);
      l.recommended_max_us = s.value("recommended_max_us", l.configured_max_us);
      l.min_excess_us = Get(s, "min_excess_us");
      l.max_excess_us = Get(s, "max_excess_us");
      ev.servos.push_back(l);
    }
    ev.notes = j.at("limits").value("notes", std::vector<std::string>{});
    d->limits = ev;
  }
}

// The "steps" entries of evaluation.json, when present.
void ReadStepsJson(const json& j, ReportData* d) {
  if (j.contains("steps")) {
    for (const json& s : j.at("steps")) {
      StepTrace t;
      t.gain = Get(s, "gain");
      t.amplitude_deg = Get(s, "amplitude_deg");
      t.trial = s.value("trial", 0);
      t.eye_axis = s.value("eye_axis", "");
      t.t_s = Vec(s, "t_s");
      t.y = Vec(s, "y");
      t.residual_px = Get(s, "residual_px");
      if (s.contains("info")) t.info = StepInfoFromJson(s.at("info"));
      t.simulated = s.value("simulated", false);
      if (const auto st = calib::TrialStatusFromName(s.value("status", "ok"))) t.status = *st;
      t.reason = s.value("reason", "");
      t.controller = s.value("controller", "p-loop");
      d->steps.push_back(t);
    }
  }
}

// The "gains" entries of evaluation.json, when present.
void ReadGainsJson(const json& j, ReportData* d) {
  if (j.contains("gains") && !j.at("gains").is_null()) {
    const json& g = j.at("gains");
    GainStudy s;
    s.delay_frames = g.value("delay_frames", 3);
    s.fps = Get(g, "fps", 30);
    for (const json& r : g.at("simulated")) s.simulated.push_back(GainFromJson(r));
    s.critical_gain = Get(g, "critical_gain");
    s.monotone_gain = Get(g, "monotone_gain");
    if (g.contains("fastest") && !g.at("fastest").is_null()) s.fastest = GainFromJson(g.at("fastest"));
    s.amplitudes_deg = Vec(g, "amplitudes_deg");
    s.lower_bound_fast_s = Vec(g, "lower_bound_fast_s");
    s.lower_bound_slow_s = Vec(g, "lower_bound_slow_s");
    d->gains = s;
  }
}

// The "settling" entries of evaluation.json, when present.
void ReadSettlingJson(const json& j, ReportData* d) {
  if (j.contains("settling") && !j.at("settling").is_null()) {
    const json& js = j.at("settling");
    fitting::SettlingStudy st;
    const json& m = js.at("model");
    st.model.fps = Get(m, "fps", 30);
    st.model.exposure_delay_s = Get(m, "exposure_delay_s");
    st.model.slew_us_per_s = Get(m, "slew_us_per_s");
    st.model.lag_s = Get(m, "lag_s");
    st.model.hysteresis_us = Get(m, "hysteresis_us", 0);
    st.model.px_per_us = Get(m, "px_per_us");
    st.model.nominal_px_per_us = Get(m, "nominal_px_per_us");
    st.model.noise_px = Get(m, "noise_px");
    st.model.tolerance_px = Get(m, "tolerance_px");
    st.model.max_step_us = m.value("max_step_us", 60);
    st.model.latency_frames = m.value("latency_frames", 0);
    st.slew_source = js.value("slew_source", std::string("fitted"));
    st.lag_source = js.value("lag_source", std::string("fitted"));
    st.motion.slew_from_prior = st.slew_source == "prior";
    st.motion.lag_from_prior = st.lag_source == "prior";
    st.motion.slew_determined = st.slew_source == "fitted";
    st.motion.lag_determined = st.lag_source == "fitted";
    st.latency_ms = Get(js, "latency_ms");
    st.ideal_delay_frames = js.value("ideal_delay_frames", 3);
    st.deg_per_us = Get(js, "deg_per_us");
    st.servo = js.value("servo", -1);
    for (const json& r : js.at("rows")) {
      fitting::SettlingRow x;
      x.gain = Get(r, "gain");
      x.amplitude_deg = Get(r, "amplitude_deg");
      x.num_trials = r.value("num_trials", 0);
      x.num_ok = r.value("num_ok", 0);
      x.num_settled = r.value("num_settled", 0);
      x.measured_median_s = Get(r, "measured_median_s");
      x.measured_lo_s = Get(r, "measured_lo_s");
      x.measured_hi_s = Get(r, "measured_hi_s");
      x.predicted_settled = r.value("predicted_settled", 0);
      x.predicted_runs = r.value("predicted_runs", 0);
      x.predicted_median_s = Get(r, "predicted_median_s");
      x.predicted_lo_s = Get(r, "predicted_lo_s");
      x.predicted_hi_s = Get(r, "predicted_hi_s");
      x.ideal_s = Get(r, "ideal_s");
      x.ideal_stable = r.value("ideal_stable", false);
      x.band = Get(r, "band", 0.02);
      x.no_servo_dynamics_s = Get(r, "no_servo_dynamics_s");
      x.no_dead_zone_s = Get(r, "no_dead_zone_s");
      x.agreement = r.value("agreement", "");
      x.why = r.value("why", "");
      st.rows.push_back(x);
    }
    for (const json& c : js.at("curve")) {
      auto num = [&](int i) { return c.at(i).is_null() ? kNaN : c.at(i).get<double>(); };
      st.curve.push_back({num(0), num(1), num(2), num(3), num(4), num(5)});
    }
    st.notes = js.value("notes", std::vector<std::string>{});
    d->settling = st;
  }
}

// The "saccade" entries of evaluation.json, when present.
void ReadSaccadeJson(const json& j, ReportData* d) {
  if (j.contains("saccade") && !j.at("saccade").is_null()) {
    const json& js = j.at("saccade");
    evaluation::SaccadeEvaluation sa;
    sa.amplitude_deg = Get(js, "amplitude_deg", 10);
    sa.slew_deg_per_s = Get(js, "slew_deg_per_s");
    sa.exposure_delay_s = Get(js, "exposure_delay_s");
    sa.fps = Get(js, "fps", 30);
    sa.bound_s = Get(js, "bound_s");
    sa.num_trials = js.value("num_trials", 0);
    sa.num_ok = js.value("num_ok", 0);
    sa.num_settled = js.value("num_settled", 0);
    sa.median_s = Get(js, "median_s");
    sa.lo_s = Get(js, "lo_s");
    sa.hi_s = Get(js, "hi_s");
    sa.ratio_to_bound = Get(js, "ratio_to_bound");
    sa.ploop_gain = Get(js, "ploop_gain", 0.1);
    sa.ploop_trials = js.value("ploop_trials", 0);
    sa.ploop_settled = js.value("ploop_settled", 0);
    sa.ploop_median_s = Get(js, "ploop_median_s");
    sa.speedup_vs_ploop = Get(js, "speedup_vs_ploop");
    sa.notes = js.value("notes", std::vector<std::string>{});
    d->saccade = sa;
  }
}

}  // namespace

json EvaluationToJson(const ReportData& d) {
  json j;
  j["format"] = "owlcal-evaluation";
  if (!d.result.run_id.empty()) j["run_id"] = d.result.run_id;  // results.json's run
  j["robot"] = RobotConfigToJson(d.config);
  j["settings"] = d.settings;
  if (d.truth) {
    fitting::CalibrationResult tmp;
    tmp.head = *d.truth;
    j["truth_head"] = fitting::ToJson(tmp)["head"];
  }
  AddRangingJson(d, &j);
  AddLimitsJson(d, &j);
  json steps = json::array();
  for (const auto& s : d.steps)
    steps.push_back({{"gain", s.gain},
                     {"amplitude_deg", s.amplitude_deg},
                     {"trial", s.trial},
                     {"eye_axis", s.eye_axis},
                     {"t_s", VecJson(s.t_s)},
                     {"y", VecJson(s.y)},
                     {"residual_px", io::JsonNumber(s.residual_px)},
                     {"info", StepInfoJson(s.info)},
                     {"simulated", s.simulated},
                     {"status", calib::TrialStatusName(s.status)},
                     {"reason", s.reason},
                     {"controller", s.controller}});
  j["steps"] = steps;
  AddGainsJson(d, &j);
  AddSettlingJson(d, &j);
  AddSaccadeJson(d, &j);
  json res = json::array();
  for (const auto& r : d.residuals) res.push_back({r.eye, r.frame, r.x, r.y, r.dx, r.dy});
  j["residuals"] = res;  // [eye, frame, x, y, dx, dy]
  json cov = json::array();
  for (const auto& c : d.coverage) cov.push_back({c.eye, c.x, c.y});
  j["coverage"] = cov;  // [eye, x, y]
  json views = json::array();
  for (const auto& v : d.views)
    views.push_back({{"eye", v.eye},
                     {"frame", v.frame},
                     {"name", v.name},
                     {"rms_px", io::JsonNumber(v.rms_px)},
                     {"corners", v.num_corners},
                     {"over_1px", v.num_over_1px}});
  j["views"] = views;
  json boards = json::array();
  for (const auto& b : d.boards) {
    json c = json::array();
    for (const auto& p : b.corners_in_cam) c.push_back({p.x(), p.y(), p.z()});
    boards.push_back({{"eye", b.eye}, {"frame", b.frame}, {"corners_in_cam", c}});
  }
  j["boards"] = boards;
  return j;
}

void EvaluationFromJson(const json& j, ReportData* d) {
  if (j.contains("robot")) d->config = RobotConfigFromJson(j.at("robot"));
  if (j.contains("settings")) d->settings = j.at("settings");
  if (j.contains("truth_head") && !j.at("truth_head").is_null()) {
    json r = {{"parameters", json::array()}, {"head", j.at("truth_head")}};
    d->truth = fitting::ResultFromJson(r).head;
  }
  ReadRangingJson(j, d);
  ReadLimitsJson(j, d);
  d->steps.clear();
  ReadStepsJson(j, d);
  ReadGainsJson(j, d);
  d->settling.reset();
  ReadSettlingJson(j, d);
  d->saccade.reset();
  ReadSaccadeJson(j, d);
  d->residuals.clear();
  if (j.contains("residuals"))
    for (const json& r : j.at("residuals"))
      d->residuals.push_back({r.at(0).get<int>(),
                              r.at(1).get<int>(),
                              r.at(2).get<double>(),
                              r.at(3).get<double>(),
                              r.at(4).get<double>(),
                              r.at(5).get<double>()});
  d->coverage.clear();
  if (j.contains("coverage"))
    for (const json& c : j.at("coverage"))
      d->coverage.push_back({c.at(0).get<int>(), c.at(1).get<double>(), c.at(2).get<double>()});
  d->views.clear();
  if (j.contains("views"))
    for (const json& v : j.at("views"))
      d->views.push_back({v.at("eye").get<int>(),
                          v.at("frame").get<int>(),
                          v.value("name", std::string()),
                          Get(v, "rms_px"),
                          v.value("corners", 0),
                          v.value("over_1px", 0)});
  d->boards.clear();
  if (j.contains("boards"))
    for (const json& b : j.at("boards")) {
      BoardOutline o;
      o.eye = b.at("eye").get<int>();
      o.frame = b.at("frame").get<int>();
      const json& c = b.at("corners_in_cam");
      if (c.size() != 4) throw std::runtime_error("boards[].corners_in_cam must have 4 points");
      for (int k = 0; k < 4; ++k) o.corners_in_cam[k] = Eigen::Vector3d(c[k].at(0), c[k].at(1), c[k].at(2));
      d->boards.push_back(o);
    }
}

ReportData ReadReportData(const std::string& dir) {
  fitting::CheckOneRun(dir);  // results.json, evaluation.json and the exports of one run
  ReportData d;
  d.result = fitting::ReadResultJson(dir + "/results.json");
  const std::string ev = dir + "/evaluation.json";
  if (std::filesystem::exists(ev)) {
    const json j = io::ReadJsonFileStrict(ev);  // a key given twice is an error
    try {
      EvaluationFromJson(j, &d);
    } catch (const std::exception& e) {
      throw std::runtime_error("evaluation file " + ev + ": " + e.what());
    }
  }
  return d;
}

void WriteReportData(const ReportData& d, const std::string& dir) {
  std::filesystem::create_directories(dir);
  fitting::WriteResultJson(d.result, dir + "/results.json");
  WriteTextFile(dir + "/evaluation.json", EvaluationToJson(d).dump(1) + "\n");
}

}  // namespace owlcal::reports
