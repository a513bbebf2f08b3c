// WriteReport: the figures, the tables and report/index.html, one self-contained page (every
// figure embedded as a PNG data: URI) in the order of a lab report, with only the sections
// that have data, and a print stylesheet (A4, figures kept whole, table headers repeated).
#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <future>
#include <map>
#include <set>
#include <sstream>

#include "fitting/radtan_refit.h"
#include "owlcal_version.h"
#include "reports/figures.h"
#include "reports/gnuplot_figure.h"
#include "reports/report.h"
#include "reports/summary.h"

namespace owlcal::reports {
namespace {

std::string NowUtc() {
  std::time_t t = std::time(nullptr);
  char buf[64];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S UTC", std::gmtime(&t));
  return buf;
}

std::string Base64File(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  const std::string in((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve(4 * ((in.size() + 2) / 3));
  for (size_t i = 0; i < in.size(); i += 3) {
    const unsigned a = static_cast<unsigned char>(in[i]);
    const unsigned b = i + 1 < in.size() ? static_cast<unsigned char>(in[i + 1]) : 0;
    const unsigned c = i + 2 < in.size() ? static_cast<unsigned char>(in[i + 2]) : 0;
    const unsigned v = (a << 16) | (b << 8) | c;
    out += k[(v >> 18) & 63];
    out += k[(v >> 12) & 63];
    out += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    out += i + 2 < in.size() ? k[v & 63] : '=';
  }
  return out;
}

const char* kStyle = R"CSS(
body{font-family:"DejaVu Sans",Arial,sans-serif;max-width:1150px;margin:1.5em auto;padding:0 1em;line-height:1.4;color:#222}
h1{font-size:1.6em;margin-bottom:.2em}h2{border-bottom:2px solid #ccc;padding-bottom:.15em;margin-top:1.6em}
h3{margin-top:1.3em}
.meta{color:#555;font-size:90%}
nav{font-size:90%;margin:.6em 0}nav a{margin-right:.8em}
.summary{border:2px solid #bbb;border-radius:6px;padding:.6em 1em;margin:1em 0}
.verdict{font-size:1.25em;font-weight:bold;padding:.35em .6em;border-radius:4px;margin:.2em 0 .6em}
.verdict.ok{background:#e3f4e1;color:#1d5e1a}.verdict.warn{background:#fff3d6;color:#7a5200}.verdict.bad{background:#fde2e1;color:#8e1b17}
.cols{display:flex;gap:1.5em;flex-wrap:wrap}.cols>div{flex:1 1 420px}
ul.tight{margin:.2em 0;padding-left:1.2em}ul.tight li{margin:.15em 0}
figure{margin:1em 0;break-inside:avoid}figure img{max-width:100%;border:1px solid #ddd;display:block}
figcaption{font-size:90%;margin-top:.3em}
.pair{display:flex;gap:1em;flex-wrap:wrap}.pair figure{flex:1 1 460px;margin:.6em 0}
table{border-collapse:collapse;margin:.8em 0;font-size:88%}
th,td{border:1px solid #ccc;padding:2px 7px;text-align:left;vertical-align:top}
th.num,td.num{text-align:right;font-variant-numeric:tabular-nums}
thead th{background:#f0f0f0}
caption{font-weight:bold;text-align:left;padding:4px 0}
.files{font-size:85%;color:#555}.warn{color:#a00}
.scroll{max-height:36em;overflow:auto}
@page{size:A4;margin:14mm 12mm}
@media print{
 body{max-width:none;margin:0;padding:0;font-size:9.5pt}
 nav,.files{display:none}
 h2{break-after:avoid;margin-top:1em}h3{break-after:avoid}
 figure{break-inside:avoid;margin:.4em 0}
 figure img{max-height:8.5cm;width:auto;max-width:100%;margin:0 auto}
 .pair figure{flex:1 1 45%}.pair figure img{max-height:7cm}
 table{font-size:7.5pt;break-inside:auto}thead{display:table-header-group}tr{break-inside:avoid}
 .scroll{max-height:none;overflow:visible}
 a{color:inherit;text-decoration:none}
}
)CSS";

struct Page {
  std::map<std::string, std::string> figures;  // name -> <figure> html
  std::map<std::string, std::string> tables;   // name -> <table> html + links
  std::set<std::string> used;

  std::string Figure(const std::string& n) {
    if (!figures.count(n)) return "";
    used.insert(n);
    return figures[n];
  }
  // Figures named by a prefix (e.g. "servo_"), in their order of creation.
  std::string FiguresWith(const std::vector<std::string>& order, const std::string& prefix) {
    std::string o;
    for (const auto& n : order)
      if (n.rfind(prefix, 0) == 0 && !used.count(n)) o += Figure(n);
    return o;
  }
  std::string Pair(const std::string& a, const std::string& b) {
    const std::string fa = Figure(a), fb = Figure(b);
    if (fa.empty() && fb.empty()) return "";
    return "<div class=\"pair\">" + fa + fb + "</div>\n";
  }
  std::string Table(const std::string& n) { return tables.count(n) ? tables[n] : ""; }
};

// A table of the parameters whose name starts with one of the prefixes.
reports::Table ParameterSubset(const reports::Table& all,
                               const std::string& name,
                               const std::string& caption,
                               const std::vector<std::string>& prefixes) {
  reports::Table t{name, caption, all.header, {}};
  for (const auto& r : all.rows)
    for (const auto& p : prefixes)
      if (r[0].rfind(p, 0) == 0) {
        t.rows.push_back(r);
        break;
      }
  return t;
}

// Settings as a two-column table (nested values as compact text), never a raw JSON dump.
reports::Table SettingsTable(const nlohmann::json& settings, const nlohmann::json& inputs) {
  reports::Table t{"settings", "Settings and inputs of this run", {"setting", "value"}, {}};
  auto add = [&](const std::string& prefix, const nlohmann::json& j) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      const nlohmann::json& v = it.value();
      if (v.is_object()) {
        for (auto jt = v.begin(); jt != v.end(); ++jt) {
          std::string text = jt.value().is_string() ? jt.value().get<std::string>() : jt.value().dump();
          if (text.size() > 160) text = text.substr(0, 157) + "...";
          t.rows.push_back({prefix + it.key() + "." + jt.key(), text});
        }
      } else {
        std::string text = v.is_string() ? v.get<std::string>() : v.dump();
        if (text.size() > 160) text = text.substr(0, 157) + "...";
        t.rows.push_back({prefix + it.key(), text});
      }
    }
  };
  add("", settings);
  add("fit input: ", inputs);
  return t;
}

// The figures drawn (when `draw`) or written, each as a <figure> of the page, in `order`.
void PlaceFigures(const ReportData& d,
                  const std::string& fig_dir,
                  bool draw,
                  ReportOutput* out,
                  Page* page,
                  std::vector<std::string>* order) {
  // Each figure is one gnuplot process: two are drawn at a time (figures_in_flight), then placed
  // in their order.
  constexpr size_t figures_in_flight = 2;
  const std::vector<reports::Figure> figures = MakeAllFigures(d);
  std::filesystem::create_directories(fig_dir);
  std::vector<std::future<FigureFiles>> drawn(figures.size());
  auto start = [&](size_t i) {
    drawn[i] = std::async(std::launch::async,
                          [&figures, &fig_dir, draw, i] { return WriteFigure(figures[i], fig_dir, draw); });
  };
  for (size_t i = 0; i < std::min(figures_in_flight, figures.size()); ++i) start(i);
  for (size_t i = 0; i < figures.size(); ++i) {
    const reports::Figure& f = figures[i];
    const FigureFiles ff = drawn[i].get();
    if (i + figures_in_flight < figures.size()) start(i + figures_in_flight);
    out->figures.push_back(f.name);
    order->push_back(f.name);
    if (draw && !ff.drawn) out->warnings.push_back(ff.message);
    std::ostringstream h;
    h << "<figure id=\"fig-" << f.name << "\">\n";
    if (ff.drawn)
      h << "<img src=\"data:image/png;base64," << Base64File(ff.png) << "\" alt=\"" << HtmlEscape(f.title) << "\">\n";
    else
      h << "<p class=\"warn\">not drawn: " << HtmlEscape(ff.message) << "</p>\n";
    h << "<figcaption><b>" << HtmlEscape(f.title) << ".</b> " << HtmlEscape(f.caption)
      << " <span class=\"files\">[<a href=\"../figures/" << f.name << ".svg\">SVG</a> | "
      << (ff.pdf.empty() ? "" : "<a href=\"../figures/" + f.name + ".pdf\">PDF</a> | ") << "<a href=\"../figures/"
      << f.name << ".csv\">CSV</a> | <a href=\"../figures/" << f.name
      << ".gp\">gnuplot</a>]</span></figcaption>\n</figure>\n";
    page->figures[f.name] = h.str();
  }
}

// MakeTables and the page's own: the parameter subsets, the truth comparison's worst rows and
// the settings.
std::vector<reports::Table> PageTables(const ReportData& d) {
  std::vector<reports::Table> tables = MakeTables(d);
  const reports::Table* params = nullptr;
  for (const auto& t : tables)
    if (t.name == "parameters") params = &t;
  if (params) {
    const reports::Table all = *params;
    tables.push_back(ParameterSubset(all, "intrinsics", "Camera intrinsics (1\u03c3)", {"left.", "right."}));
    tables.push_back(
        ParameterSubset(all, "stereo", "Stereo extrinsics: x_right = R x_left + T (1\u03c3)", {"stereo."}));
    tables.push_back(ParameterSubset(all, "servo_maps", "Servo maps and head geometry (1\u03c3)", {"servo.", "head."}));
    reports::Table other{"other_parameters", "Other fitted parameters (1\u03c3)", all.header, {}};
    for (const auto& r : all.rows)
      if (r[0].rfind("left.", 0) && r[0].rfind("right.", 0) && r[0].rfind("stereo.", 0) && r[0].rfind("servo.", 0) &&
          r[0].rfind("head.", 0))
        other.rows.push_back(r);
    tables.push_back(other);
  }
  // The truth comparison on the page: the ten largest |error / sigma| (every parameter table
  // above already carries its truth column; the full comparison is in tables/).
  for (const auto& t : std::vector<reports::Table>(tables))
    if (t.name == "truth_comparison") {
      reports::Table worst{"truth_worst", t.caption + ": the ten largest |error / \u03c3|", t.header, t.rows};
      std::sort(worst.rows.begin(), worst.rows.end(), [](const auto& a, const auto& b) {
        const double za = a[6].empty() ? 0 : std::abs(std::stod(a[6])),
                     zb = b[6].empty() ? 0 : std::abs(std::stod(b[6]));
        return za > zb;
      });
      if (worst.rows.size() > 10) worst.rows.resize(10);
      tables.push_back(worst);
    }
  tables.push_back(SettingsTable(d.settings, d.result.inputs));
  return tables;
}

// Each table with rows (and "undetermined" always) written to tab_dir and placed on the page.
void PlaceTables(const std::vector<reports::Table>& tables, const std::string& tab_dir, ReportOutput* out, Page* page) {
  for (const reports::Table& t : tables) {
    if (t.rows.empty() && t.name != "undetermined") continue;
    WriteTable(t, tab_dir);
    out->tables.push_back(t.name);
    page->tables[t.name] = "<div class=\"scroll\">" + ToHtml(t) + "</div><p class=\"files\">[<a href=\"../tables/" +
                           t.name + ".csv\">CSV</a> | <a href=\"../tables/" + t.name +
                           ".md\">Markdown</a> | <a href=\"../tables/" + t.name + ".tex\">LaTeX</a>]</p>\n";
  }
}

// The page's body and its navigation, with numbered sections.
struct ReportSections {
  std::ostringstream body, nav;
  int section = 0;
  void H2(const std::string& id, const std::string& title) {
    ++section;
    nav << "<a href=\"#" << id << "\">" << section << ". " << HtmlEscape(title) << "</a>";
    body << "<h2 id=\"" << id << "\">" << section << ". " << HtmlEscape(title) << "</h2>\n";
  }
};

// 1. Summary (one screen): verdict, reasons, headline results, warnings and next steps.
void WriteSummarySection(const ReportData& d, const std::string& tab_dir, std::ostringstream* out) {
  std::ostringstream& body = *out;
  const Summary sum = MakeSummary(d);
  body << "<div class=\"summary\" id=\"summary\">\n<div class=\"verdict " << sum.level << "\">"
       << HtmlEscape(sum.verdict) << "</div>\n";
  if (!sum.reasons.empty()) {
    body << "<ul class=\"tight\">";
    for (const auto& r : sum.reasons) body << "<li>" << HtmlEscape(r) << "</li>";
    body << "</ul>\n";
  }
  {
    reports::Table t{"headline", "Headline results (value \u00b1 1\u03c3)", {"quantity", "value", "unit", "note"}, {}};
    for (const auto& x : sum.headlines) t.rows.push_back({x.quantity, x.value, x.unit, x.note});
    if (!t.rows.empty()) {
      WriteTable(t, tab_dir);
      body << ToHtml(t);
    }
  }
  body << "<div class=\"cols\"><div><b>Warnings</b>";
  if (sum.warnings.empty())
    body << "<p>None.</p>";
  else {
    body << "<ul class=\"tight\">";
    for (const auto& w : sum.warnings) body << "<li>" << HtmlEscape(w) << "</li>";
    body << "</ul>";
  }
  body << "</div><div><b>What to do next</b><ul class=\"tight\">";
  for (const auto& n : sum.next_steps) body << "<li>" << HtmlEscape(n) << "</li>";
  body << "</ul></div></div>\n</div>\n";
}

// 2. Method.
void WriteMethodSection(const ReportData& d, std::ostringstream* out) {
  std::ostringstream& body = *out;
  const std::string cmd = d.settings.value("command", std::string());
  body << "<p>";
  if (cmd.find("calibrate-images") != std::string::npos)
    body << "Stereo calibration from a folder of image pairs (" << HtmlEscape(d.settings.value("images", std::string()))
         << ") with the target " << HtmlEscape(d.settings.value("target", std::string()))
         << ": corners detected in each image, both cameras and the stereo extrinsics fitted jointly with Ceres "
            "(board poses marginalised in the covariance). No robot was involved.";
  else
    body << "Robot <b>" << HtmlEscape(d.config.name) << "</b>. The standard protocols moved the eyes and the neck and "
         << "recorded each dataset; the intrinsics and stereo extrinsics were fitted from the chessboard views, the "
            "servo maps, IPD and camera mounting from the servo sweep (one Ceres problem), and ranging, step "
            "responses and limits were evaluated from their datasets.";
  body << " Every number carries its standard deviation from the fit covariance; the settings are listed in the "
          "appendix.</p>\n";
}

// 3. Results, one subsection per kind of data present.
void WriteResultsSection(const ReportData& d, const std::vector<std::string>& order, Page* p, std::ostringstream* out) {
  std::ostringstream& body = *out;
  Page& page = *p;
  const bool cameras = d.result.cameras[0] || d.result.cameras[1];
  if (cameras) {
    body << "<h3 id=\"intrinsics\">Camera intrinsics</h3>\n" << page.Table("intrinsics");
    if (page.tables.count("lens_model"))
      body << "<p>Lens model chosen by cross-validation: each fold of frames is left out of the fit and then placed "
              "by its board pose alone with the fitted cameras (and extrinsics); the model with the smaller held-out "
              "RMS predicts views it has not seen better (a richer model that fits the noise does not).</p>\n"
           << page.Table("lens_model");
    if (page.tables.count("board_warp"))
      body << "<p>Board bow chosen the same way: flat against mrcal's two-parameter deflection, each held-out view "
              "placed on the bow its training folds fitted.</p>\n"
           << page.Table("board_warp");
    if (page.tables.count("reference_comparison"))
      body << "<p>Against a reference calibration of the same images (e.g. the course's stereo_calib xml): A the "
              "reference, B OpenCV's stereoCalibrate with the course program's flags on owlcal's corners, D the same "
              "with owlcal's lens model, E owlcal with a flat board, C owlcal. The four parts add up to C \u2212 A; "
              "the caption gives each part's share, weighted by owlcal's \u03c3.</p>\n"
           << page.Table("reference_comparison");
    body << page.Figure("view_rms") << page.Pair("residual_field_left", "residual_field_right")
         << page.Pair("residual_hist_left", "residual_hist_right") << page.Pair("uncertainty_left", "uncertainty_right")
         << page.Pair("distortion_left", "distortion_right") << page.Figure("coverage");
  }
  if (d.result.stereo)
    body << "<h3 id=\"stereo\">Stereo extrinsics</h3>\n" << page.Table("stereo") << page.Figure("poses_3d");
  if (page.figures.count("servo_maps")) {
    body << "<h3 id=\"servos\">Servo maps and head</h3>\n"
         << page.Table("servo_maps") << page.Figure("servo_maps") << page.FiguresWith(order, "servo_")
         << page.Table("servo_map_truth") << page.Table("tag_coverage") << page.Table("tag_servo_ends");
  }
  if (d.ranging) {
    body << "<h3 id=\"ranging\">Vergence ranging</h3>\n<p>Range = distance from the midpoint of the two eye rotation "
            "centres to the closest point of the two gaze rays; each ray starts at the camera centre given by the "
            "calibrated servo maps at the settled command and passes through the target's detected pixel. \u03c3 "
            "propagates the calibration covariance and the pixel noise. The course's nominal method uses 0.113 "
            "deg/\u00b5s, the configured centres, IPD 65 mm and the sine rule.</p>\n"
         << page.Table("ranging_summary") << page.Figure("range_error") << page.Table("ranging");
  }
  if (!d.steps.empty() || d.gains) {
    body
        << "<h3 id=\"control\">Step response and gain</h3>\n<p>Metrics as MATLAB stepinfo with y_init = 0 and y_final "
           "= 1 (y in fractions of the step): rise time from 10 % to 90 %, settling time = the first sample after "
           "which |y \u2212 1| \u2264 2 % for good, overshoot and undershoot in % of the step, peak and its time. "
           "Steady-state error = 1 \u2212 the mean of y over the last 10 % of the trial: the part of the step not done "
           "when the trial ended (non-zero for a trial that did not settle). Model: y(k+1) = y(k) + K (1 \u2212 y(k "
           "\u2212 d)).</p>\n"
        << page.Figure("step_responses") << page.Figure("settling_vs_gain") << page.Table("settling_model")
        << page.Table("saccade") << page.Table("gain_study") << page.Table("step_metrics");
  }
  if (d.limits) {
    body << "<h3 id=\"limits\">Servo limits</h3>\n" << page.Figure("limits") << page.Table("limits");
    if (!d.limits->notes.empty()) {
      body << "<ul class=\"tight\">";
      for (const auto& n : d.limits->notes) body << "<li>" << HtmlEscape(n) << "</li>";
      body << "</ul>\n";
    }
  }
  if (page.tables.count("latency_check") || page.tables.count("alignment_check") || page.tables.count("field_of_view"))
    body << "<h3 id=\"reference_checks\">Checks against references</h3>\n<p>Measured numbers against what they "
            "should be: the latency protocol's reading against the virtual Owl's truth (on a real robot there is no "
            "truth column), the alignment of the eyes against the vertical disparity a block matcher tolerates, and "
            "the fitted field of view and focal length against the Pi camera datasheet in the course notes.</p>\n"
         << page.Table("latency_check") << page.Table("alignment_check") << page.Table("field_of_view");
  if (page.tables.count("truth_comparison"))
    body << "<h3 id=\"truth\">Ground-truth comparison (virtual Owl)</h3>\n<p>Every parameter table above has a truth "
            "column; the full comparison is <a "
            "href=\"../tables/truth_comparison.csv\">tables/truth_comparison.csv</a>.</p>\n"
         << page.Table("truth_worst");
  // Any figure not placed above (added by another part of owlcal) still appears.
  std::string rest;
  for (const auto& n : order)
    if (!page.used.count(n)) rest += page.Figure(n);
  if (!rest.empty()) body << "<h3 id=\"other\">Other figures</h3>\n" << rest;
}

// Appendix C: the files of the calibration folder.
void WriteFilesAppendix(const ReportData& d, std::ostringstream* out) {
  std::ostringstream& body = *out;
  body << "<h3>C. Files</h3>\n<ul class=\"tight\">"
       << "<li><a href=\"../results.json\">results.json</a>: every parameter with value, \u03c3, unit (and truth)</li>"
       << "<li><a href=\"../calibration.yaml\">calibration.yaml</a>: OpenCV, lengths in metres</li>"
       << "<li><a href=\"../intrinsics.xml\">intrinsics.xml</a>, <a href=\"../extrinsics.xml\">extrinsics.xml</a>: the "
          "course's files, lengths in millimetres</li>"
       << "<li><a href=\"../exports/\">exports/</a>: ROS camera_info (alpha 0), Kalibr camchain (radtan4";
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics* cam =
        d.result.cameras[e] ? &*d.result.cameras[e] : (d.result.head ? &d.result.head->intrinsics[e] : nullptr);
    if (!cam) continue;
    const auto fit = fitting::FitRadtan4(*cam);
    if (fit.ok)
      body << (fit.exact ? std::string("; ") + models::kEyeNames[e] + " exact"
                         : std::string("; ") + models::kEyeNames[e] + " refit max " + Fmt(fit.max_error_px, 2) + " px");
  }
  body << "), mrcal .cameramodel with its valid-intrinsics region" << (d.result.head ? ", owl-pwm.h (C and C++)" : "")
       << "</li><li><a href=\"../figures/\">figures/</a>: PNG, SVG, PDF, tidy CSV, gnuplot data and script of each "
          "figure; <a href=\"../tables/\">tables/</a>: CSV, Markdown and LaTeX (longtable) of each table</li></ul>\n";
}

}  // namespace

ReportOutput WriteReport(const ReportData& d, const std::string& out_dir, const ReportOptions& options) {
  ReportOutput out;
  const std::string fig_dir = out_dir + "/figures", tab_dir = out_dir + "/tables", rep_dir = out_dir + "/report";
  std::filesystem::create_directories(rep_dir);
  std::string gp_term, gp_version;
  const bool have_gp = GnuplotAvailable(&gp_term, &gp_version);
  if (options.draw && !have_gp)
    out.warnings.push_back("gnuplot not found: figures written as .dat/.csv + .gp only (apt install gnuplot-nox)");

  Page page;
  std::vector<std::string> order;
  PlaceFigures(d, fig_dir, options.draw && have_gp, &out, &page, &order);
  PlaceTables(PageTables(d), tab_dir, &out, &page);

  ReportSections sections;
  std::ostringstream& body = sections.body;
  std::ostringstream& nav = sections.nav;
  WriteSummarySection(d, tab_dir, &body);

  // 2. Method.
  sections.H2("method", "Method");
  WriteMethodSection(d, &body);

  // 3. Results, one subsection per kind of data present.
  sections.H2("results", "Results");
  WriteResultsSection(d, order, &page, &body);

  // 4. Discussion.
  sections.H2("discussion", "Discussion: what the data could not determine");
  body << "<p>Parameters the data could not determine are reported as such (no \u03c3 that hides it), with the "
          "reason; the warnings say what else to keep in mind when using these numbers.</p>\n"
       << page.Table("undetermined");

  // Appendices.
  sections.H2("appendix", "Appendix");
  body << "<h3>A. Other fitted parameters</h3>\n<p>The parameters not shown in the Results; every parameter is in "
          "<a href=\"../tables/parameters.csv\">tables/parameters.csv</a> and results.json.</p>\n"
       << page.Table("other_parameters") << "<h3>B. Solver summaries</h3>\n"
       << page.Table("solver");
  WriteFilesAppendix(d, &body);
  body << "<h3>D. Settings and versions</h3>\n" << page.Table("settings");

  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << HtmlEscape(options.title)
    << "</title>\n<style>" << kStyle << "</style></head><body>\n<h1>" << HtmlEscape(options.title) << "</h1>\n"
    << "<p class=\"meta\">"
    << (d.settings.value("robot", std::string()) == "none" ? "No robot (images)"
                                                           : "Robot: " + HtmlEscape(d.config.name))
    << ". Generated " << NowUtc() << " by owlcal "
    << HtmlEscape(d.result.software_version.empty() ? OWLCAL_VERSION : d.result.software_version)
    << " (report by owlcal " << OWLCAL_VERSION << "); figures by " << HtmlEscape(have_gp ? gp_version : "no gnuplot")
    << ".</p>\n"
    << "<nav><a href=\"#summary\">Summary</a>" << nav.str() << "</nav>\n";
  for (const auto& w : out.warnings) h << "<p class=\"warn\">" << HtmlEscape(w) << "</p>\n";
  h << body.str() << "</body></html>\n";
  out.index_html = rep_dir + "/index.html";
  WriteTextFile(out.index_html, h.str());
  return out;
}

}  // namespace owlcal::reports
