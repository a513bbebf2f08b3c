#include "reports/report.h"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <sstream>

#include "fitting/servo_map_eval.h"
#include "fitting/truth_compare.h"
#include "owlcal_version.h"
#include "reports/figures.h"
#include "reports/gnuplot_figure.h"

namespace owlcal::reports {
namespace {

std::string Pct(double rel, int sig = 3) { return std::isfinite(rel) ? Fmt(100 * rel, sig) : ""; }
std::string Bool(bool b) { return b ? "yes" : "no"; }

std::string NowUtc() {
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&t));
  return buf;
}

}  // namespace

std::vector<Table> MakeTables(const ReportData& d) {
  std::vector<Table> out;
  const bool any_truth = [&] {
    for (const auto& p : d.result.parameters)
      if (p.truth) return true;
    return false;
  }();
  {
    Table t{"parameters", "Fitted parameters with their standard deviation (1 sigma)", {"name", "value", "sigma", "unit", "determined"}, {}};
    if (any_truth) {
      t.header.push_back("truth");
      t.header.push_back("error");
      t.header.push_back("error / sigma");
    }
    for (const auto& p : d.result.parameters) {
      std::vector<std::string> r = {p.name, FmtWithSigma(p.value, p.sigma), p.determined ? Fmt(p.sigma, 2) : "",
                                    p.unit, p.determined ? "yes" : "no: " + p.note};
      if (any_truth) {
        if (p.truth) {
          r.push_back(Fmt(*p.truth, 6));
          r.push_back(Fmt(p.value - *p.truth, 3));
          r.push_back(p.determined && p.sigma > 0 ? Fmt((p.value - *p.truth) / p.sigma, 2) : "");
        } else {
          r.insert(r.end(), {"", "", ""});
        }
      }
      t.rows.push_back(r);
    }
    out.push_back(t);
  }
  if (!d.result.summaries.empty()) {
    Table t{"solver", "Solver summaries", {"problem", "termination", "iterations", "RMS [px]", "residuals", "outliers", "time [s]", "usable"}, {}};
    for (const auto& s : d.result.summaries)
      t.rows.push_back({s.problem, s.termination, std::to_string(s.iterations), Fmt(s.rms_px, 4),
                        std::to_string(s.num_residuals), std::to_string(s.num_outliers), Fmt(s.time_s, 3), Bool(s.usable)});
    out.push_back(t);
  }
  {
    Table t{"undetermined", "Parameters the data could not determine, and warnings", {"parameter or warning", "reason"}, {}};
    for (const auto& p : d.result.parameters)
      if (!p.determined) t.rows.push_back({p.name, p.note});
    for (const auto& w : d.result.warnings) t.rows.push_back({"warning", w});
    out.push_back(t);
  }
  if (any_truth) {
    const fitting::TruthComparison c = fitting::CompareWithTruth(d.result);
    Table t{"truth_comparison",
            "Virtual Owl: fitted vs true values (" + std::to_string(c.num_with_sigma) + " with sigma, " +
                Pct(c.fraction_within_2sigma, 3) + " % within 2 sigma, RMS z = " + Fmt(c.rms_z, 3) + ")",
            {"name", "value", "truth", "error", "unit", "sigma", "error / sigma", "within 2 sigma"}, {}};
    for (const auto& r : c.rows)
      t.rows.push_back({r.name, Fmt(r.value, 7), Fmt(r.truth, 7), Fmt(r.error, 3), r.unit, Fmt(r.sigma, 2),
                        Fmt(r.z, 3), std::isfinite(r.z) ? Bool(r.within_2sigma) : "n/a"});
    out.push_back(t);
  }
  if (d.truth && d.result.head) {
    // Whole maps, not just their parameters: fitted minus true angle over the configured range.
    Table t{"servo_map_truth", "Virtual Owl: fitted servo maps vs the truth over each servo's configured range",
            {"servo", "range [us]", "RMS [deg]", "max |error| [deg]", "mean error [deg]"}, {}};
    for (int s = 0; s < models::kNumServos; ++s) {
      const fitting::Parameter* p = d.result.Find("servo." + std::string(models::kServoNames[s]) + ".deg_per_us");
      if (!p || !p->determined) continue;
      const models::ServoConfig& c = d.config.servos[s];
      const fitting::ServoMapError e = fitting::ServoMapErrorOverRange(*d.result.head, *d.truth, s, c.min_us, c.max_us);
      t.rows.push_back({models::kServoNames[s], std::to_string(c.min_us) + "-" + std::to_string(c.max_us),
                        Fmt(e.rms_deg, 3), Fmt(e.max_abs_deg, 3), Fmt(e.mean_deg, 3)});
    }
    if (!t.rows.empty()) out.push_back(t);
  }
  if (d.ranging) {
    const auto& r = *d.ranging;
    Table t{"ranging", "Vergence ranging per fixation", {"fixation", "true [m]", "calibrated [m]", "error [%]", "2 sigma [%]", "within 2 sigma", "ray gap [mm]", "course nominal [m]", "nominal error [%]"}, {}};
    for (const auto& x : r.rows)
      t.rows.push_back({std::to_string(x.index), Fmt(x.true_m, 4), Fmt(x.range_m, 5), Pct(x.rel_error),
                        Pct(2 * x.sigma_m / x.true_m), x.ok ? Bool(std::abs(x.error_m) <= 2 * x.sigma_m) : "",
                        Fmt(1000 * x.gap_m, 3), x.nominal_m ? Fmt(*x.nominal_m, 4) : "none: gaze rays diverge",
                        x.nominal_m ? Pct(x.nominal_rel_error) : ""});
    out.push_back(t);
    Table s{"ranging_summary", "Vergence ranging summary", {"quantity", "value"}, {}};
    s.rows = {{"fixations evaluated", std::to_string(r.num_ok) + " of " + std::to_string(r.rows.size())},
              {"RMS relative error, calibrated [%]", Pct(r.rms_rel_error)},
              {"mean |relative error|, calibrated [%]", Pct(r.mean_abs_rel_error)},
              {"max |relative error|, calibrated [%]", Pct(r.max_abs_rel_error)},
              {"fraction within +-2 sigma [%]", Pct(r.fraction_within_2sigma)},
              {"RMS relative error, course nominal method [%]", Pct(r.nominal_rms_rel_error)},
              {"fixations the course nominal method can range",
               std::to_string(std::count_if(r.rows.begin(), r.rows.end(), [](const auto& x) { return x.nominal_m.has_value(); })) +
                   " of " + std::to_string(r.rows.size()) + " (the others: its gaze rays diverge)"}};
    out.push_back(s);
  }
  if (!d.steps.empty()) {
    Table t{"step_metrics", "Step-response metrics (MATLAB stepinfo with y_init = 0, y_final = 1 in fractions of the step)",
            {"gain", "step [deg]", "trial", "rise 10-90 % [s]", "settling 2 % [s]", "overshoot [%]", "undershoot [%]", "peak [-]", "peak time [s]", "steady-state error [-]", "residual offset [px]", "source"}, {}};
    for (const auto& s : d.steps)
      t.rows.push_back({Fmt(s.gain, 3), Fmt(s.amplitude_deg, 3), std::to_string(s.trial), Fmt(s.info.rise_time, 3),
                        s.info.settled ? Fmt(s.info.settling_time, 3) : "not settled", Fmt(s.info.overshoot_pct, 3),
                        Fmt(s.info.undershoot_pct, 3), Fmt(s.info.peak, 4), Fmt(s.info.peak_time, 3),
                        Fmt(s.info.steady_state_error, 3), Fmt(s.residual_px, 3), s.simulated ? "model" : "measured"});
    out.push_back(t);
  }
  if (d.gains) {
    const auto& g = *d.gains;
    Table t{"gain_study", "Incremental P loop with latency (model): gain limits and the fastest stable gain", {"quantity", "value"}, {}};
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
    out.push_back(t);
  }
  if (d.limits) {
    Table t{"limits", "Servo limits: configured vs measured",
            {"servo", "configured min [us]", "configured max [us]", "measured min [us]", "low end", "measured max [us]", "high end", "measured range [deg]", "recommended min [us]", "recommended max [us]"}, {}};
    for (const auto& s : d.limits->servos)
      t.rows.push_back({s.name, std::to_string(s.configured_min_us), std::to_string(s.configured_max_us),
                        s.measured_min_us ? Fmt(*s.measured_min_us, 6) : "", s.measured_min_us ? fitting::LimitCauseName(s.min_cause) : "",
                        s.measured_max_us ? Fmt(*s.measured_max_us, 6) : "", s.measured_max_us ? fitting::LimitCauseName(s.max_cause) : "",
                        std::isfinite(s.measured_max_deg - s.measured_min_deg) ? Fmt(std::abs(s.measured_max_deg - s.measured_min_deg), 4) : "",
                        std::to_string(s.recommended_min_us), std::to_string(s.recommended_max_us)});
    out.push_back(t);
  }
  return out;
}

ReportOutput WriteReport(const ReportData& d, const std::string& out_dir, const ReportOptions& options) {
  ReportOutput out;
  const std::string fig_dir = out_dir + "/figures", tab_dir = out_dir + "/tables", rep_dir = out_dir + "/report";
  std::filesystem::create_directories(rep_dir);
  std::string gp_term, gp_version;
  const bool have_gp = GnuplotAvailable(&gp_term, &gp_version);
  if (options.draw && !have_gp) out.warnings.push_back("gnuplot not found: figures written as .csv + .gp only (apt install gnuplot-nox)");

  std::ostringstream figs_html;
  for (const Figure& f : MakeAllFigures(d)) {
    const FigureFiles ff = WriteFigure(f, fig_dir, options.draw && have_gp);
    out.figures.push_back(f.name);
    if (options.draw && have_gp && !ff.drawn) out.warnings.push_back(ff.message);
    figs_html << "<figure id=\"fig-" << f.name << "\">\n";
    if (ff.drawn)
      figs_html << "<a href=\"../figures/" << f.name << ".svg\"><img src=\"../figures/" << f.name << ".png\" alt=\""
                << HtmlEscape(f.title) << "\"></a>\n";
    else
      figs_html << "<p class=\"warn\">not drawn: " << HtmlEscape(ff.message) << "</p>\n";
    figs_html << "<figcaption><b>" << HtmlEscape(f.title) << ".</b> " << HtmlEscape(f.caption)
              << " <span class=\"files\">[<a href=\"../figures/" << f.name << ".svg\">SVG</a> | <a href=\"../figures/"
              << f.name << ".csv\">CSV</a> | <a href=\"../figures/" << f.name << ".gp\">gnuplot</a>]</span></figcaption>\n</figure>\n";
  }

  std::map<std::string, std::string> tables_html;
  for (const Table& t : MakeTables(d)) {
    WriteTable(t, tab_dir);
    out.tables.push_back(t.name);
    tables_html[t.name] = ToHtml(t) + "<p class=\"files\">[<a href=\"../tables/" + t.name + ".csv\">CSV</a> | <a href=\"../tables/" +
                          t.name + ".md\">Markdown</a> | <a href=\"../tables/" + t.name + ".tex\">LaTeX</a>]</p>\n";
  }
  auto table = [&](const std::string& n) { return tables_html.count(n) ? tables_html[n] : std::string(); };

  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << HtmlEscape(options.title)
    << "</title>\n<style>body{font-family:sans-serif;max-width:1100px;margin:2em auto;line-height:1.4}"
       "img{max-width:100%;border:1px solid #ddd}figure{margin:2em 0}table{border-collapse:collapse;margin:1em 0;font-size:90%}"
       "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right}td:first-child,th:first-child{text-align:left}"
       "caption{font-weight:bold;text-align:left;padding:4px 0}.files{font-size:85%;color:#555}.warn{color:#b00}"
       "pre{background:#f4f4f4;padding:8px;overflow-x:auto;font-size:85%}</style></head><body>\n";
  h << "<h1>" << HtmlEscape(options.title) << "</h1>\n";
  h << "<p>Robot: <b>" << HtmlEscape(d.config.name) << "</b>. Generated " << NowUtc() << " by owlcal "
    << HtmlEscape(d.result.software_version.empty() ? OWLCAL_VERSION : d.result.software_version) << " (report by owlcal "
    << OWLCAL_VERSION << "); figures by " << HtmlEscape(have_gp ? gp_version : "no gnuplot") << ".</p>\n";
  h << "<p>Contents: <a href=\"#calibration\">calibration</a> | <a href=\"#ranging\">ranging</a> | <a href=\"#control\">control</a>"
       " | <a href=\"#limits\">limits</a> | <a href=\"#truth\">ground truth</a> | <a href=\"#undetermined\">undetermined</a>"
       " | <a href=\"#settings\">settings</a>. Files: <a href=\"../results.json\">results.json</a>, "
       "<a href=\"../calibration.yaml\">calibration.yaml</a> (OpenCV), <a href=\"../exports/\">exports</a>.</p>\n";
  for (const auto& w : out.warnings) h << "<p class=\"warn\">" << HtmlEscape(w) << "</p>\n";

  h << "<h2 id=\"calibration\">Calibration</h2>\n" << table("parameters") << table("solver");
  h << "<h2 id=\"figures\">Figures</h2>\n" << figs_html.str();
  h << "<h2 id=\"ranging\">Vergence ranging</h2>\n"
    << "<p>Range = distance from the midpoint of the two eye rotation centres to the closest point of the two gaze rays; each "
       "ray starts at the camera centre given by the calibrated servo maps at the settled command and passes through the "
       "target's detected pixel (the residual offset after settling). Sigma propagates the calibration covariance and the pixel "
       "noise. The course's nominal method uses 0.113 deg/us, the configured centres, IPD 65 mm and the sine rule.</p>\n"
    << table("ranging_summary") << table("ranging");
  h << "<h2 id=\"control\">Step response and gain</h2>\n"
    << "<p>Definitions (as MATLAB stepinfo with an explicit initial value y_init and final value y_final; y in fractions of "
       "the step): rise time = time from 10 % to 90 % of (y_final - y_init), first crossings, interpolated; settling time = "
       "the first sample after which |y - y_final| &lt;= 2 % of |y_final - y_init| for good; overshoot = max excursion beyond "
       "y_final in % of the step; undershoot = wrong-way excursion in % of the step; peak and peak time of the largest "
       "excursion; steady-state error = reference - y_final. Model: y(k+1) = y(k) + K (1 - y(k - d)).</p>\n"
    << table("gain_study") << table("step_metrics");
  h << "<h2 id=\"limits\">Servo limits</h2>\n" << table("limits");
  if (d.limits && !d.limits->notes.empty()) {
    h << "<ul>";
    for (const auto& n : d.limits->notes) h << "<li>" << HtmlEscape(n) << "</li>";
    h << "</ul>\n";
  }
  h << "<h2 id=\"truth\">Ground-truth comparison (virtual Owl)</h2>\n";
  if (tables_html.count("truth_comparison")) h << table("truth_comparison");
  if (tables_html.count("servo_map_truth")) h << table("servo_map_truth");
  else h << "<p>No ground truth: this run used a real robot, or no truth file was given.</p>\n";
  h << "<h2 id=\"undetermined\">Undetermined parameters and warnings</h2>\n" << table("undetermined");
  h << "<h2 id=\"settings\">Settings and versions</h2>\n<p>Inputs recorded by the fits:</p>\n<pre>"
    << HtmlEscape(d.result.inputs.dump(2)) << "</pre>\n<p>Run settings:</p>\n<pre>" << HtmlEscape(d.settings.dump(2))
    << "</pre>\n<p>Robot configuration:</p>\n<pre>" << HtmlEscape(RobotConfigToJson(d.config).dump(2)) << "</pre>\n";
  h << "</body></html>\n";
  out.index_html = rep_dir + "/index.html";
  WriteTextFile(out.index_html, h.str());
  return out;
}

}  // namespace owlcal::reports
