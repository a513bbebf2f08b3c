#include "reports/figures.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "evaluation/ranging_eval.h"
#include "evaluation/servo_map_eval.h"
#include "fitting/distortion_field.h"
#include "reports/camera_figures.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

constexpr const char* kColours[] = {
    "#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2", "#17becf"};
const char* Colour(size_t i) { return kColours[i % 8]; }
std::string Lc(size_t i) { return std::string("lc rgb '") + Colour(i) + "'"; }

}  // namespace

std::vector<Figure> MakeServoFigures(const ReportData& d) {
  std::vector<Figure> out;
  if (!d.result.head) return out;
  Figure all{"servo_maps",
             "Servo maps: joint angle vs pulse width",
             "pulse width [\u00b5s]",
             "joint angle [deg]",
             {},
             {"set bmargin 6"},
             "outside bottom center horizontal"};
  all.caption =
      "Fitted PWM-to-angle map of every servo over its configured range (solid); dashed: the truth of the "
      "virtual Owl (on top of the fit at this scale: the deviation figures show the difference).";
  bool truth_titled = false;
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig& c = d.config.servos[s];
    const std::string sname = models::kServoNames[s];
    // Was this servo's map fitted at all? (The neck's centre is a gauge held at the robot
    // file's value, so the scale decides.)
    const fitting::Parameter* ps = d.result.Find("servo." + sname + ".deg_per_us");
    if (!ps || !ps->determined) continue;
    Series fit{sname + " fitted", "lines lw 2.5 " + Lc(s), "1:2", {"pwm_us", "angle_deg"}, {}};
    Series truth{
        truth_titled ? "" : "truth (dashed)", "lines lw 1.5 dt 2 lc rgb 'black'", "1:2", {"pwm_us", "angle_deg"}, {}};
    truth_titled = truth_titled || d.truth.has_value();
    Figure dev{"servo_" + std::string(sname == "Neck" ? "neck" : sname) + "_deviation",
               sname + ": fitted map minus the course's nominal map (0.113 deg/\u00b5s at the configured centre)",
               "pulse width [\u00b5s]",
               "angle difference [deg]",
               {},
               {"set bmargin 6"},
               "outside bottom center horizontal"};
    for (auto& ch : dev.name) ch = std::tolower(ch);
    dev.caption = sname +
                  ": the fitted map minus the nominal course map, with its \u00b12\u03c3 band from the fit "
                  "covariance (centre, scale, quadratic and cubic terms). On the virtual Owl the truth is dashed.";
    Series band{"fit \u00b12\u03c3",
                "filledcurves fs transparent solid 0.25 noborder " + Lc(s),
                "1:2:3",
                {"pwm_us", "lo_deg", "hi_deg"},
                {}};
    Series dfit{"fitted - nominal", "lines lw 2.5 " + Lc(s), "1:2", {"pwm_us", "diff_deg"}, {}};
    Series dtruth{"truth - nominal", "lines lw 2 dt 2 lc rgb 'black'", "1:2", {"pwm_us", "diff_deg"}, {}};
    // The map with its sigma band over the parameters the data determined (evaluation/servo_map_eval.h).
    for (const evaluation::ServoMapSample& m :
         evaluation::SampleServoMap(d.result, c, s, d.truth ? &*d.truth : nullptr)) {
      fit.rows.push_back({m.pwm_us, m.angle_deg});
      band.rows.push_back(
          {m.pwm_us, m.angle_deg - m.nominal_deg - 2 * m.sigma_deg, m.angle_deg - m.nominal_deg + 2 * m.sigma_deg});
      dfit.rows.push_back({m.pwm_us, m.angle_deg - m.nominal_deg});
      if (d.truth) {
        truth.rows.push_back({m.pwm_us, m.truth_deg});
        dtruth.rows.push_back({m.pwm_us, m.truth_deg - m.nominal_deg});
      }
    }
    all.series.push_back(fit);
    if (d.truth) all.series.push_back(truth);
    dev.series = {band, dfit};
    if (d.truth) dev.series.push_back(dtruth);
    out.push_back(dev);
  }
  if (!all.series.empty()) out.insert(out.begin(), all);
  return out;
}

std::vector<Figure> MakeDistortionFigures(const ReportData& d) {
  std::vector<Figure> out;
  for (int e = 0; e < 2; ++e) {
    const std::optional<models::CameraIntrinsics>& cam =
        d.result.cameras[e] ? d.result.cameras[e]
                            : (d.result.head ? std::optional(d.result.head->intrinsics[e]) : std::nullopt);
    if (!cam) continue;
    const std::string eye = models::kEyeNames[e];
    // Displacement of each pixel by the distortion (fitting/distortion_field.h).
    std::vector<std::vector<double>> rows;
    double maxd = 0;
    for (const fitting::DistortionArrow& a : fitting::DistortionField(*cam)) {
      maxd = std::max(maxd, a.norm_px);
      rows.push_back({a.x_pinhole_px, a.y_pinhole_px, a.dx_px, a.dy_px, a.norm_px});
    }
    if (rows.empty()) continue;
    const double scale = maxd > 0 ? 40.0 / maxd : 1.0;  // longest arrow 40 px on the plot
    for (auto& r : rows) {
      r.push_back(r[2] * scale);
      r.push_back(r[3] * scale);
    }
    Figure f{"distortion_" + eye,
             eye + " lens distortion (arrows x" + Fmt(scale, 2) + "; colour = displacement [px])",
             "x [px]",
             "y [px]",
             {},
             {},
             "off"};
    f.settings = {"set size ratio -1",
                  "set xrange [-40:" + std::to_string(cam->width + 40) + "]",
                  "set yrange [" + std::to_string(cam->height + 40) + ":-40]",
                  "set cblabel 'displacement [px]'",
                  kViridis};
    f.series.push_back({"",
                        "vectors head size 6,20 filled lw 2 lc palette",
                        "1:2:6:7:5",
                        {"x_pinhole_px", "y_pinhole_px", "dx_px", "dy_px", "norm_px", "dx_plot", "dy_plot"},
                        rows});
    f.caption = "Where the " + eye +
                " lens moves each image point (pinhole position to distorted position), from the "
                "fitted distortion coefficients; the largest displacement is " +
                Fmt(maxd, 3) + " px.";
    f.width_px = 900;
    f.height_px = 700;
    out.push_back(f);
  }
  return out;
}

std::optional<Figure> MakeRangeErrorFigure(const ReportData& d) {
  if (!d.ranging) return std::nullopt;
  const auto& r = *d.ranging;
  Figure f{"range_error",
           "Vergence range error vs true distance",
           "true distance [m]",
           "range error [% of distance]",
           {},
           {},
           "top left"};
  f.height_px = 800;
  f.caption =
      "Range from the calibrated head (gaze rays through the settled target pixels) with \u00b12\u03c3 error bars "
      "from the calibration covariance and pixel noise, the course's nominal method (0.113 deg/\u00b5s, 65 mm, "
      "sine rule), and the theory: \u00b11 \u00b5s on one eye with the nominal formula, and the calibrated "
      "\u00b12\u03c3 band. The axis shows the calibrated result; points beyond it sit on its edge (open "
      "triangles) and the ranging table lists their values.";
  Series band{"calibrated theory \u00b12\u03c3",
              "filledcurves fs transparent solid 0.2 noborder " + Lc(0),
              "1:2:3",
              {"distance_m", "lo_pct", "hi_pct"},
              {}};
  Series q_hi{
      "nominal formula, 1 \u00b5s on one eye", "lines lw 1.5 dt 3 lc rgb '#555555'", "1:2", {"distance_m", "pct"}, {}};
  Series q_lo{"", "lines lw 1.5 dt 3 lc rgb '#555555'", "1:2", {"distance_m", "pct"}, {}};
  for (const auto& t : r.theory) {
    band.rows.push_back({t.distance_m, -200 * t.calibrated_sigma_rel, 200 * t.calibrated_sigma_rel});
    q_hi.rows.push_back({t.distance_m, 100 * t.nominal_1us_rel});
    q_lo.rows.push_back({t.distance_m, -100 * t.nominal_1us_rel});
  }
  Series cal{"calibrated (\u00b12\u03c3)",
             "yerrorbars pt 7 ps 1.3 lw 1.5 " + Lc(0),
             "1:2:3",
             {"true_m", "err_pct", "two_sigma_pct"},
             {}};
  Series nom{"course nominal method", "points pt 9 ps 1.5 " + Lc(1), "1:2", {"true_m", "err_pct"}, {}};
  double ymax = 0;
  for (const auto& x : r.rows) {
    if (x.ok) {
      cal.rows.push_back({x.true_m, 100 * x.rel_error, 200 * x.sigma_m / x.true_m});
      ymax = std::max(ymax, std::abs(100 * x.rel_error) + 200 * x.sigma_m / x.true_m);
    }
    if (x.nominal_m) nom.rows.push_back({x.true_m, 100 * x.nominal_rel_error});
  }
  if (!band.rows.empty()) f.series.push_back(band);
  if (!q_hi.rows.empty()) {
    f.series.push_back(q_hi);
    f.series.push_back(q_lo);
  }
  f.series.push_back(cal);
  f.settings.push_back("set xzeroaxis lt -1 lw 1");
  // The axis is scaled to the useful data: the calibrated errors with their 2 sigma bars and the
  // calibrated theory band over the measured distances (at least +-0.5 %). Anything beyond
  // (the course method's errors are often tens or hundreds of %) is drawn at the edge.
  double dmin = 1e9, dmax = 0;
  for (const auto& x : r.rows) {
    dmin = std::min(dmin, x.true_m);
    dmax = std::max(dmax, x.true_m);
  }
  double band_max = 0;
  for (const auto& t : r.theory)
    if (t.distance_m >= dmin - 0.05 && t.distance_m <= dmax + 0.05)
      band_max = std::max(band_max, 200 * t.calibrated_sigma_rel);
  const double lim = std::max({0.5, 1.3 * ymax, 1.3 * band_max});
  f.settings.push_back("set yrange [" + Fmt(-lim, 3) + ":" + Fmt(lim, 3) + "]");
  f.settings.push_back("set xrange [" + Fmt(std::max(0.0, dmin - 0.1), 3) + ":" + Fmt(dmax + 0.1, 3) + "]");
  // Nominal-method points beyond the axis are drawn at its edge as open triangles pointing the
  // way they left, and the legend says how far they went (the table has every value).
  Series nom_in = nom, nom_off{"", "points pt 8 ps 1.5 " + Lc(1), "1:2", {"true_m", "edge_pct"}, {}};
  Series nom_off_lo{"", "points pt 10 ps 1.5 " + Lc(1), "1:2", {"true_m", "edge_pct"}, {}};
  nom_in.rows.clear();
  double off_max = 0;
  bool any_negative = false;
  for (const auto& x : nom.rows) {
    any_negative = any_negative || x[1] < 0;
    if (std::abs(x[1]) <= lim) {
      nom_in.rows.push_back(x);
    } else {
      (x[1] > 0 ? nom_off : nom_off_lo).rows.push_back({x[0], (x[1] > 0 ? 0.93 : -0.93) * lim});
      off_max = std::max(off_max, std::abs(x[1]));
    }
  }
  const size_t num_off = nom_off.rows.size() + nom_off_lo.rows.size();
  if (num_off > 0)
    (nom_off.rows.empty() ? nom_off_lo : nom_off).title = "course nominal, off scale: " + std::to_string(num_off) +
                                                          " points up to " + std::to_string(int(std::lround(off_max))) +
                                                          " % (table)";
  // Fixations that were not ranged (lost, off target, not settled): crosses on the bottom edge.
  Series cal_none{"not ranged (fixation not ok: see the ranging table)",
                  "points pt 2 ps 2 lw 2 " + Lc(0),
                  "1:2",
                  {"true_m", "edge_pct"},
                  {}};
  for (const auto& x : r.rows)
    if (!x.ok) cal_none.rows.push_back({x.true_m, -0.93 * lim});
  // Fixations the course method cannot range at all (its gaze rays diverge): open squares at
  // the top edge at their true distance.
  Series nom_none{
      "course nominal: no range (rays diverge)", "points pt 4 ps 1.5 " + Lc(1), "1:2", {"true_m", "edge_pct"}, {}};
  for (const auto& x : r.rows)
    if (x.ok && !x.nominal_m) nom_none.rows.push_back({x.true_m, 0.93 * lim});
  // The key below the plot: it hides no point.
  (void)any_negative;
  f.key = "outside bottom center horizontal maxcols 2";
  if (!nom_in.rows.empty()) f.series.push_back(nom_in);
  if (!nom_off.rows.empty()) f.series.push_back(nom_off);
  if (!nom_off_lo.rows.empty()) f.series.push_back(nom_off_lo);
  if (!cal_none.rows.empty()) f.series.push_back(cal_none);
  if (!nom_none.rows.empty()) f.series.push_back(nom_none);
  int titled = 0;
  for (const auto& x : f.series) titled += !x.title.empty();
  f.settings.push_back("set bmargin " + std::to_string(5 + titled));
  return f;
}

std::optional<Figure> MakeStepResponseFigure(const ReportData& d) {
  if (d.steps.empty()) return std::nullopt;
  Figure f{"step_responses",
           "Fixation step responses",
           "time since the step [s]",
           "fraction of the step done [-]",
           {},
           {},
           "bottom right"};
  f.caption =
      "Target offset turned into the fraction of the step done (0 at rest, 1 on target) for each gain of the P "
      "loop and for the calibrated saccade; dashed: the 2 % settling band.";
  // One colour per gain of the P loop, and one for the calibrated saccade.
  std::map<std::pair<std::string, double>, int> colour;
  auto key = [](const StepTrace& s) { return std::make_pair(s.controller, s.controller == "p-loop" ? s.gain : 0.0); };
  for (const auto& s : d.steps) colour.emplace(key(s), int(colour.size()));
  std::set<std::pair<std::string, double>> titled;
  double tmax = 0;
  for (const auto& s : d.steps) {
    if (s.t_s.empty()) continue;  // a failed or skipped trial: a row of the step table, no curve
    const int c = colour[key(s)];
    std::string title;
    if (!titled.count(key(s))) {
      title = s.controller == "p-loop" ? "K = " + Fmt(s.gain, 3) + (s.simulated ? " (model)" : "")
                                       : "calibrated " + s.controller;
      titled.insert(key(s));
    }
    Series ser{title,
               std::string(s.simulated ? "lines lw 2 dt 2 " : "linespoints pt 7 ps 0.6 lw 2 ") + Lc(c),
               "1:2",
               {"t_s", "y"},
               {}};
    for (size_t k = 0; k < s.t_s.size() && k < s.y.size(); ++k) {
      ser.rows.push_back({s.t_s[k], s.y[k]});
      tmax = std::max(tmax, s.t_s[k]);
    }
    f.series.push_back(ser);
  }
  f.series.push_back({"2 % band", "lines lw 1 dt 2 lc rgb 'black'", "1:2", {"t_s", "y"}, {{0, 1.02}, {tmax, 1.02}}});
  f.series.push_back({"", "lines lw 1 dt 2 lc rgb 'black'", "1:2", {"t_s", "y"}, {{0, 0.98}, {tmax, 0.98}}});
  return f;
}

std::optional<Figure> MakeSettlingFigure(const ReportData& d) {
  if (!d.gains) return std::nullopt;
  const GainStudy& g = *d.gains;
  Figure f{"settling_vs_gain",
           "2 % settling time vs proportional gain",
           "gain K [-]",
           "settling time [s]",
           {},
           {"set bmargin 11"},
           "outside bottom center horizontal maxrows 4"};
  f.height_px = 760;
  f.width_px = 1100;
  f.caption = "Settling time of the course's incremental P loop with " + std::to_string(g.delay_frames) +
              " frames of delay at " + Fmt(g.fps, 3) +
              " fps (model), the measured trials, the stability limit K_crit = " + Fmt(g.critical_gain, 3) +
              " and the physical lower bound for a 10 deg step (slew + latency + one frame).";
  Series model{"P-loop model (d = " + std::to_string(g.delay_frames) + ")",
               "lines lw 2.5 " + Lc(0),
               "1:2",
               {"gain", "settling_s"},
               {}};
  double ymax = 0;
  for (const auto& r : g.simulated)
    if (r.settled) {
      model.rows.push_back({r.gain, r.settling_time_s});
      ymax = std::max(ymax, r.settling_time_s);
    } else {
      model.rows.push_back({r.gain, NAN});
    }
  f.series.push_back(model);
  Series meas{"measured trials", "points pt 7 ps 1.5 " + Lc(1), "1:2", {"gain", "settling_s"}, {}};
  for (const auto& s : d.steps)
    if (!s.simulated && s.status == calib::TrialStatus::kOk && s.controller == "p-loop" && s.info.settled)
      meas.rows.push_back({s.gain, s.info.settling_time});
  if (!meas.rows.empty()) f.series.push_back(meas);
  if (d.settling) {
    // The loop model (fitted slew, lag, latency, dead zone) for the 10 deg step, or the largest
    // amplitude measured, with its range, and the measured medians with their min-max.
    const auto& st = *d.settling;
    double amp = 0;
    for (const auto& r : st.rows) amp = (std::abs(r.amplitude_deg - 10) < std::abs(amp - 10)) ? r.amplitude_deg : amp;
    Series band{
        "loop model range", "filledcurves fs transparent solid 0.2 " + Lc(4), "1:2:3", {"gain", "lo_s", "hi_s"}, {}};
    Series mid{
        "loop model, " + Fmt(amp, 3) + "\u00b0 step", "lines lw 2.5 " + Lc(4), "1:2", {"gain", "settling_s"}, {}};
    for (const auto& c : st.curve)
      if (c.amplitude_deg == amp) {
        band.rows.push_back({c.gain, c.lo_s, c.hi_s});
        mid.rows.push_back({c.gain, c.median_s});
        if (std::isfinite(c.hi_s)) ymax = std::max(ymax, std::min(c.hi_s, 6.0));
      }
    if (!mid.rows.empty()) {
      f.series.push_back(band);
      f.series.push_back(mid);
    }
    Series med{"measured median (min\u2013max)",
               "yerrorbars pt 9 ps 1.5 " + Lc(1),
               "1:2:3:4",
               {"gain", "median_s", "lo_s", "hi_s"},
               {}};
    for (const auto& r : st.rows)
      if (std::isfinite(r.measured_median_s))
        med.rows.push_back({r.gain, r.measured_median_s, r.measured_lo_s, r.measured_hi_s});
    if (!med.rows.empty()) f.series.push_back(med);
    f.caption +=
        " The loop model (purple, for the " + Fmt(amp, 3) +
        "\u00b0 step) is the measured loop: latency, slew and lag fitted from the step frames, the servo's "
        "backlash, the controller's dead zone; the settling table says where it and the measurement differ, and why.";
  }
  if (g.fastest)
    f.series.push_back(
        {"model fastest: K = " + Fmt(g.fastest->gain, 3) + ", " + Fmt(g.fastest->settling_time_s, 3) + " s",
         "points pt 5 ps 2 lc rgb 'black'",
         "1:2",
         {"gain", "settling_s"},
         {{g.fastest->gain, g.fastest->settling_time_s}}});
  const double xmax = std::max(0.6, g.critical_gain * 1.4);
  for (size_t i = 0; i < g.amplitudes_deg.size(); ++i) {
    if (g.amplitudes_deg[i] != 10.0) continue;
    f.series.push_back({"bound 10°: 400 °/s + 100 ms",
                        "lines lw 2 dt 4 " + Lc(2),
                        "1:2",
                        {"gain", "s"},
                        {{0, g.lower_bound_fast_s[i]}, {xmax, g.lower_bound_fast_s[i]}}});
    f.series.push_back({"bound 10°: 300 °/s + 150 ms",
                        "lines lw 2 dt 5 " + Lc(3),
                        "1:2",
                        {"gain", "s"},
                        {{0, g.lower_bound_slow_s[i]}, {xmax, g.lower_bound_slow_s[i]}}});
  }
  f.series.push_back({"K_crit = " + Fmt(g.critical_gain, 3),
                      "lines lw 2 lc rgb '#888888'",
                      "1:2",
                      {"gain", "s"},
                      {{g.critical_gain, 0}, {g.critical_gain, std::min(ymax, 6.0)}}});
  f.settings.push_back("set xrange [0:" + Fmt(xmax, 3) + "]");
  f.settings.push_back("set yrange [0:" + Fmt(std::min(ymax, 6.0), 3) + "]");
  return f;
}

std::optional<Figure> MakeLimitsFigure(const ReportData& d) {
  if (!d.limits) return std::nullopt;
  Figure f{"limits",
           "Servo limits: configured vs measured",
           "pulse width [\u00b5s]",
           "",
           {},
           {},
           "outside bottom center horizontal"};
  f.caption =
      "For each servo: the configured range (robot file, grey), the measured range (colour) and what ended it "
      "(end-stop, socket rim, or the configured limit).";
  Series cfg{"configured", "vectors nohead lw 12 lc rgb '#bbbbbb'", "1:2:3:4", {"from_us", "y", "dx_us", "dy"}, {}};
  Series mea{"measured", "vectors nohead lw 6 " + Lc(0), "1:2:3:4", {"from_us", "y", "dx_us", "dy"}, {}};
  Series ctr{"configured centre", "points pt 13 ps 2 lc rgb 'black'", "1:2", {"centre_us", "y"}, {}};
  // The range the protocols after the bring-up were confined to (pipeline/bring_up.h).
  Series used{
      "used after the bring-up", "vectors nohead lw 2 lc rgb 'black'", "1:2:3:4", {"from_us", "y", "dx_us", "dy"}, {}};
  const nlohmann::json bring_up = d.result.diagnostics.value("bring_up", nlohmann::json::object());
  std::string ytics = "set ytics (";
  const int n = int(d.limits->servos.size());
  for (int i = 0; i < n; ++i) {
    const auto& s = d.limits->servos[i];
    const double y = n - i;
    ytics += std::string(i ? ", " : "") + "'" + s.name + "' " + Fmt(y, 3);
    cfg.rows.push_back({double(s.configured_min_us), y + 0.15, double(s.configured_max_us - s.configured_min_us), 0});
    ctr.rows.push_back({double(s.configured_centre_us), y + 0.15});
    const double lo = s.measured_min_us.value_or(s.configured_min_us),
                 hi = s.measured_max_us.value_or(s.configured_max_us);
    if (s.measured_min_us || s.measured_max_us) mea.rows.push_back({lo, y - 0.15, hi - lo, 0});
    auto label = [&](double x, evaluation::LimitCause c, bool right) {
      f.settings.push_back("set label '" + std::string(evaluation::LimitCauseName(c)) + "' at " + Fmt(x, 6) + "," +
                           Fmt(y - 0.15, 4) + (right ? " left offset 1,0" : " right offset -1,0") + " font ',12'");
    };
    if (s.measured_min_us) label(lo, s.min_cause, false);
    if (s.measured_max_us) label(hi, s.max_cause, true);
    if (bring_up.contains("servos") && bring_up["servos"].is_array() && i < int(bring_up["servos"].size())) {
      const nlohmann::json u = bring_up["servos"][i].value("used", nlohmann::json::object());
      if (u.contains("min_us") && u.contains("max_us"))
        used.rows.push_back({u["min_us"].get<double>(), y, u["max_us"].get<double>() - u["min_us"].get<double>(), 0});
    }
  }
  f.settings.push_back(ytics + ")");
  f.settings.push_back("set yrange [0.3:" + Fmt(n + 0.7, 3) + "]");
  f.settings.push_back("set xrange [850:2250]");
  f.settings.push_back("set bmargin 6");
  f.series = {cfg, mea, ctr};
  if (!used.rows.empty()) {
    f.series.push_back(used);
    f.caption +=
        " Black: the range every protocol after the bring-up kept to (the measured end-stops, also "
        "those behind the rim, minus 15 \u00b5s).";
  }
  return f;
}

std::optional<Figure> MakeCoverageFigure(const ReportData& d) {
  if (d.coverage.empty()) return std::nullopt;
  Figure f{"coverage",
           "Image coverage of the detected calibration corners",
           "x [px]",
           "y [px]",
           {},
           {},
           "outside bottom center horizontal"};
  f.caption =
      "Every detected corner used for the intrinsics, per eye. Distortion is only determined where corners were seen.";
  f.settings = {"set size ratio -1",
                "set xrange [0:" + std::to_string(d.config.image_width - 1) + "]",
                "set yrange [" + std::to_string(d.config.image_height - 1) + ":0]",
                "set bmargin 6"};
  for (int e = 0; e < 2; ++e) {
    Series s{std::string(models::kEyeNames[e]) + " eye",
             std::string("points pt ") + (e ? "6" : "7") + " ps 0.5 " + Lc(e),
             "1:2",
             {"x_px", "y_px"},
             {}};
    for (const auto& c : d.coverage)
      if (c.eye == e) s.rows.push_back({c.x, c.y});
    if (!s.rows.empty()) f.series.push_back(s);
  }
  f.width_px = 900;
  f.height_px = 780;
  return f;
}

std::vector<Figure> MakeAllFigures(const ReportData& d) {
  std::vector<Figure> all;
  auto add = [&](std::optional<Figure> f) {
    if (f) all.push_back(std::move(*f));
  };
  for (auto& f : MakeServoFigures(d)) all.push_back(f);
  for (auto& f : MakeCameraFigures(d)) all.push_back(f);
  for (auto& f : MakeDistortionFigures(d)) all.push_back(f);
  add(MakeCoverageFigure(d));
  add(MakeRangeErrorFigure(d));
  add(MakeStepResponseFigure(d));
  add(MakeSettlingFigure(d));
  add(MakeLimitsFigure(d));
  return all;
}

}  // namespace owlcal::reports
