#include "reports/sharpness_study_page.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "calib/observation_io.h"
#include "evaluation/range_images_ranging.h"
#include "evaluation/study_cells.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

namespace fs = std::filesystem;

// sharpness_images: the edge blur per image.
reports::Table SharpnessImagesTable(const evaluation::SharpnessStudy& s) {
  reports::Table images{"sharpness_images",
                        "Edge blur per image (status ok, or why not)",
                        {"image",
                         "eye",
                         "distance_m",
                         "status",
                         "reason",
                         "roi",
                         "roi_x",
                         "roi_y",
                         "roi_w",
                         "roi_h",
                         "edges",
                         "blur_sigma_px",
                         "blur_sigma_se_px",
                         "laplacian_variance",
                         "contrast"},
                        {}};
  for (const evaluation::SharpnessRow& r : s.rows) {
    const calib::EdgeSharpness& e = r.sharpness;
    const bool ok = r.status == "ok";
    images.rows.push_back({fs::path(r.image).filename().string(),
                           models::kEyeNames[r.eye],
                           evaluation::FxOrInf(r.distance_m, 3),
                           r.status,
                           r.reason,
                           r.roi_source,
                           r.roi_source.empty() ? "" : std::to_string(e.roi.x),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.y),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.width),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.height),
                           std::to_string(e.num_edges),
                           ok ? evaluation::FxOrInf(e.blur_sigma_px, 4) : "",
                           ok ? evaluation::FxOrInf(e.blur_sigma_se_px, 4) : "",
                           ok ? evaluation::FxOrInf(e.laplacian_variance, 5) : "",
                           r.roi_source.empty() ? "" : evaluation::FxOrInf(e.contrast, 1)});
  }
  return images;
}

// sharpness: the blur per distance and eye.
reports::Table SharpnessByDistanceTable(const evaluation::SharpnessStudy& s) {
  reports::Table by{
      "sharpness",
      "Edge blur against distance (mean of the ok images, standard error; Laplacian variance / contrast^2)",
      {"eye", "distance_m", "ok", "images", "blur_sigma_px", "se_px", "fit_px", "laplacian_variance"},
      {}};
  for (int e = 0; e < 2; ++e)
    for (const evaluation::SharpnessAtDistance& a : s.by_distance[e])
      by.rows.push_back({models::kEyeNames[e],
                         evaluation::FxOrInf(a.distance_m, 3),
                         std::to_string(a.num_ok),
                         std::to_string(a.num_images),
                         a.num_ok ? evaluation::FxOrInf(a.sigma_px, 4) : "",
                         a.num_ok ? evaluation::FxOrInf(a.se_px, 4) : "",
                         s.fit[e].ok ? evaluation::FxOrInf(s.fit[e].Predict(a.distance_m), 4) : "",
                         a.num_ok ? evaluation::FxOrInf(a.laplacian_variance, 5) : ""});
  return by;
}

// sharpness_fit: the focus fit per eye.
reports::Table SharpnessFitTable(const evaluation::SharpnessStudy& s) {
  reports::Table fit{
      "sharpness_fit",
      "Focus and depth of field per eye: sigma(d)^2 = s0^2 + k^2 (1/d - 1/focus)^2; depth of field where the blur "
      "is at most " +
          evaluation::FxOrInf(s.fit[0].dof_blur_ratio, 3) + " x s0 (sharpness within " +
          evaluation::FxOrInf(100 / std::max(1.0, s.fit[0].dof_blur_ratio), 0) + " % of its best)",
      {"eye", "quantity", "value", "sigma", "unit", "truth", "z"},
      {}};
  for (int e = 0; e < 2; ++e) {
    const fitting::FocusFit& f = s.fit[e];
    const std::string eye = models::kEyeNames[e];
    if (!f.ok) {
      fit.rows.push_back({eye, "fit", "not fitted", "", "", "", f.reason});
      continue;
    }
    const bool t = s.truth.has_value();
    auto z = [](double v, double truth, double sg) { return sg > 0 ? evaluation::FxOrInf((v - truth) / sg, 2) : ""; };
    fit.rows.push_back({eye,
                        "in-focus blur s0",
                        evaluation::FxOrInf(f.s0_px, 3),
                        evaluation::FxOrInf(f.s0_sigma_px, 3),
                        "px",
                        "",
                        ""});
    fit.rows.push_back({eye,
                        "defocus k",
                        evaluation::FxOrInf(f.k_px_per_dioptre, 3),
                        evaluation::FxOrInf(f.k_sigma, 3),
                        "px/D",
                        t ? evaluation::FxOrInf(s.truth->k_px_per_dioptre[e], 3) : "",
                        t ? z(f.k_px_per_dioptre, s.truth->k_px_per_dioptre[e], f.k_sigma) : ""});
    if (f.focus_found) {
      fit.rows.push_back({eye,
                          "focus",
                          evaluation::FxOrInf(f.focus_dioptre, 3),
                          evaluation::FxOrInf(f.focus_dioptre_sigma, 3),
                          "D",
                          t ? evaluation::FxOrInf(1 / s.truth->focus_m, 3) : "",
                          t ? z(f.focus_dioptre, 1 / s.truth->focus_m, f.focus_dioptre_sigma) : ""});
      fit.rows.push_back({eye,
                          "focus distance",
                          evaluation::FxOrInf(f.focus_m, 3),
                          evaluation::FxOrInf(f.focus_sigma_m, 3),
                          "m",
                          t ? evaluation::FxOrInf(s.truth->focus_m, 3) : "",
                          ""});
      fit.rows.push_back({eye,
                          "depth of field, near",
                          evaluation::FxOrInf(f.dof_near_m, 3),
                          evaluation::FxOrInf(f.dof_near_sigma_m, 3),
                          "m",
                          "",
                          ""});
      // A far limit beyond the measured range is an extrapolation: said so, not given a number.
      if (f.dof_far_m > f.max_distance_m)
        fit.rows.push_back({eye,
                            "depth of field, far",
                            "beyond " + evaluation::FxOrInf(f.max_distance_m, 2),
                            "",
                            "m",
                            "",
                            std::isfinite(f.dof_far_m) ? "extrapolated: " + evaluation::FxOrInf(f.dof_far_m, 1) + " m"
                                                       : "to infinity"});
      else
        fit.rows.push_back({eye,
                            "depth of field, far",
                            evaluation::FxOrInf(f.dof_far_m, 3),
                            evaluation::FxOrInf(f.dof_far_sigma_m, 3),
                            "m",
                            "",
                            ""});
    } else {
      fit.rows.push_back({eye,
                          "focus",
                          "not determined",
                          "",
                          "",
                          t ? evaluation::FxOrInf(1 / s.truth->focus_m, 3) : "",
                          "no defocus over the measured range"});
      fit.rows.push_back(
          {eye,
           "depth of field",
           "at least " + evaluation::FxOrInf(f.dof_near_m, 2) + "-" + evaluation::FxOrInf(f.dof_far_m, 2),
           "",
           "m",
           "",
           ""});
    }
    fit.rows.push_back({eye, "chi2/dof", evaluation::FxOrInf(f.chi2_per_dof, 2), "", "", "", ""});
  }
  return fit;
}

// The figure: measured blur with 2 se bars, the fit, per eye.
reports::Figure SharpnessFigure(const evaluation::SharpnessStudy& s) {
  reports::Figure fig;
  fig.name = "sharpness";
  fig.title = "Edge blur against distance";
  fig.xlabel = "distance [m]";
  fig.ylabel = "edge blur sigma [px]";
  const char* colour[2] = {"#1f77b4", "#d62728"};
  for (int e = 0; e < 2; ++e) {
    reports::Series pts{std::string(models::kEyeNames[e]) + " eye (+-2 se)",
                        std::string("yerrorbars pt 7 ps 1.2 lc rgb '") + colour[e] + "'",
                        "1:2:($3*2)",
                        {"distance_m", "blur_sigma_px", "se_px"},
                        {}};
    for (const evaluation::SharpnessAtDistance& a : s.by_distance[e])
      if (a.num_ok) pts.rows.push_back({a.distance_m, a.sigma_px, a.se_px});
    if (!pts.rows.empty()) fig.series.push_back(pts);
    const fitting::FocusFit& f = s.fit[e];
    if (f.ok) {
      reports::Series line{
          std::string(models::kEyeNames[e]) + " fit" +
              (f.focus_found ? ", focus " + evaluation::FxOrInf(f.focus_m, 2) + " m" : ", no defocus found"),
          std::string("lines lw 2 lc rgb '") + colour[e] + "'",
          "1:2",
          {"distance_m", "fit_px"},
          {}};
      for (int i = 0; i <= 100; ++i) {
        const double d = f.min_distance_m * std::pow(f.max_distance_m / f.min_distance_m, i / 100.0);
        line.rows.push_back({d, f.Predict(d)});
      }
      fig.series.push_back(line);
    }
  }
  fig.settings = {"set logscale x", "set mxtics 10", "set grid"};
  double lo = 1e9, hi = 0;
  for (int e = 0; e < 2; ++e)
    for (const evaluation::SharpnessAtDistance& a : s.by_distance[e])
      lo = std::min(lo, a.distance_m), hi = std::max(hi, a.distance_m);
  if (hi > lo) {
    fig.settings.push_back("set xrange [" + evaluation::FxOrInf(0.85 * lo, 4) + ":" +
                           evaluation::FxOrInf(1.15 * hi, 4) + "]");
    std::string tics;  // a log axis over less than a decade needs its own labels
    for (const double t : {0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0})
      if (t >= 0.85 * lo && t <= 1.15 * hi) tics += (tics.empty() ? "" : ", ") + io::SignificantText(t, 3);
    if (!tics.empty()) fig.settings.push_back("set xtics (" + tics + ")");
  }
  // The depth of field's near limit per eye (dashed), where the fit found a focus.
  for (int e = 0; e < 2; ++e)
    if (s.fit[e].ok && s.fit[e].focus_found && s.fit[e].dof_near_m > 0.85 * lo && s.fit[e].dof_near_m < 1.15 * hi)
      fig.settings.push_back("set arrow from " + evaluation::FxOrInf(s.fit[e].dof_near_m, 4) + ", graph 0 to " +
                             evaluation::FxOrInf(s.fit[e].dof_near_m, 4) + ", graph 1 nohead dt 2 lw 1.5 lc rgb '" +
                             colour[e] + "'");
  fig.key = "top right";
  fig.caption =
      "Gaussian-equivalent edge blur per eye (mean over the ok images, bars +-2 standard errors) and the thin-lens "
      "fit; "
      "dashed: the near limit of the depth of field (blur <= " +
      evaluation::FxOrInf(s.fit[0].dof_blur_ratio, 2) + " x the in-focus blur).";
  return fig;
}

// The report page: the figure (or why not), the fit and distance tables, the notes, every image.
std::string SharpnessPageHtml(const evaluation::SharpnessStudy& s,
                              const reports::Table& images,
                              const reports::Table& by,
                              const reports::Table& fit,
                              const reports::Figure& fig,
                              const reports::FigureFiles& ff) {
  std::string html =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>owlcal lens sharpness</title>\n"
      "<style>body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em}table{border-collapse:"
      "collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:3px 8px}img{max-width:100%}</style></head><body>\n"
      "<h1>Lens sharpness against distance</h1>\n<p>Source: " +
      reports::HtmlEscape(s.source) + ". " + std::to_string(s.num_ok) + " of " +
      std::to_string(s.num_ok + s.num_failed) +
      " images measured; the blur is the Gaussian-equivalent sigma of isolated edges (calib/edge_sharpness.h)."
      "</p>\n";
  if (ff.drawn)
    html += "<figure><img src=\"../figures/sharpness.png\" alt=\"edge blur against distance\"><figcaption>" +
            reports::HtmlEscape(fig.caption) + "</figcaption></figure>\n";
  else
    html += "<p>Figure not drawn (" + reports::HtmlEscape(ff.message) +
            "): figures/sharpness.gp and .csv hold its data.</p>\n";
  for (const reports::Table& t : {fit, by}) html += reports::ToHtml(t) + "\n";
  if (!s.notes.empty()) {
    html += "<h2>Notes, failures and refusals</h2>\n<ul>\n";
    for (const std::string& n : s.notes) html += "<li>" + reports::HtmlEscape(n) + "</li>\n";
    html += "</ul>\n";
  }
  html += reports::ToHtml(images) + "\n</body></html>\n";
  return html;
}

}  // namespace

std::string WriteSharpnessStudy(const evaluation::SharpnessStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");
  std::vector<reports::Table> tables;

  const reports::Table images = SharpnessImagesTable(s);
  tables.push_back(images);
  const reports::Table by = SharpnessByDistanceTable(s);
  tables.push_back(by);
  const reports::Table fit = SharpnessFitTable(s);
  tables.push_back(fit);
  for (const reports::Table& t : tables) reports::WriteTable(t, out + "/tables");
  const reports::Figure fig = SharpnessFigure(s);
  const reports::FigureFiles ff = reports::WriteFigure(fig, out + "/figures", draw);

  nlohmann::json j = evaluation::SharpnessStudyJson(s);
  reports::WriteTextFile(out + "/sharpness.json", j.dump(2) + "\n");
  const std::string html = SharpnessPageHtml(s, images, by, fit, fig, ff);
  const std::string page = out + "/report/index.html";
  reports::WriteTextFile(page, html);
  return page;
}

}  // namespace owlcal::reports
