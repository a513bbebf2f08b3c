#include "pipeline/sharpness_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "calib/observation_io.h"
#include "evaluation/range_images_ranging.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/calibrate_pipeline.h"
#include "protocols/dataset.h"
#include "protocols/fixation.h"
#include "protocols/protocol.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace fs = std::filesystem;
namespace {

// The Owl's lens ahead of the neck axis: the eye's rotation centre 30 mm ahead
// (models::HeadGeometry) plus about 15 mm from there to the lens's centre of projection.
constexpr double kNominalCameraAheadM = 0.045;

std::string FxOrInf(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : "inf"; }

// The course's 80x80 window at (280, 200) (data/owl-real/kit2020-distance-target1/README.md),
// grown about its centre for near targets (the box label's scale goes as 1 / distance).
cv::Rect DefaultWindow(double distance_m, const cv::Size& size) {
  const int side = std::max(80, int(std::lround(80 * 0.9 / distance_m)));
  const cv::Rect r(320 - side / 2, 240 - side / 2, side, side);
  return r & cv::Rect(0, 0, size.width, size.height);
}

// The bounding box of one eye's detected corners, grown by one square (the median spacing of
// neighbouring corners).
cv::Rect BoardBox(const std::vector<Eigen::Vector2d>& px, const cv::Size& size) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& p : px) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  // Square size ~ sqrt(area per corner).
  const double sq = std::sqrt(std::max(1.0, (x1 - x0) * (y1 - y0)) / std::max<size_t>(1, px.size()));
  const cv::Rect r(int(std::floor(x0 - sq)),
                   int(std::floor(y0 - sq)),
                   int(std::ceil(x1 - x0 + 2 * sq)),
                   int(std::ceil(y1 - y0 + 2 * sq)));
  return r & cv::Rect(0, 0, size.width, size.height);
}

// square_px > 0: the board's squares in the image; the edge window must hold one edge and the
// plateaus on both sides, not the next edge: probe_px <= (square - 3) / 2, at least 2 px (a
// window of +-2 px holds the edges of a board in focus, sigma ~0.3 px, to +-6 sigma).
void Measure(
    SharpnessRow* row, const cv::Mat& image, const cv::Rect& roi, const SharpnessOptions& o, double square_px = 0) {
  calib::EdgeSharpnessOptions eo = o.edge;
  if (square_px > 0) {
    eo.probe_px = std::min(eo.probe_px, (square_px - 3) / 2);
    if (eo.probe_px < 2) {
      row->status = "unmeasurable";
      row->reason =
          "the board's squares are " + FxOrInf(square_px, 1) + " px: too small for an edge window (at least 7 px)";
      row->sharpness.roi = roi;
      return;
    }
  }
  row->sharpness = calib::MeasureEdgeSharpness(image, roi, eo);
  if (row->sharpness.ok) {
    row->status = "ok";
  } else {
    row->status = "unmeasurable";
    row->reason = row->sharpness.reason;
  }
}

// Per eye: per distance means, then the focus fit.
void Summarise(SharpnessStudy* s, const SharpnessOptions& o) {
  for (int e = 0; e < 2; ++e) {
    std::map<double, std::vector<const SharpnessRow*>> at;
    for (const SharpnessRow& r : s->rows)
      if (r.eye == e) at[r.distance_m].push_back(&r);
    std::vector<fitting::FocusSample> samples;
    for (const auto& [d, rows] : at) {
      SharpnessAtDistance a;
      a.distance_m = d;
      a.num_images = int(rows.size());
      double sum = 0, sum2 = 0, se2 = 0, lap = 0;
      for (const SharpnessRow* r : rows) {
        if (r->status != "ok") continue;
        ++a.num_ok;
        sum += r->sharpness.blur_sigma_px;
        sum2 += r->sharpness.blur_sigma_px * r->sharpness.blur_sigma_px;
        se2 += r->sharpness.blur_sigma_se_px * r->sharpness.blur_sigma_se_px;
        lap += r->sharpness.laplacian_variance;
      }
      if (a.num_ok > 0) {
        const int n = a.num_ok;
        a.sigma_px = sum / n;
        a.laplacian_variance = lap / n;
        const double within = std::sqrt(se2) / n;  // the per-image errors, combined
        const double scatter = n > 1 ? std::sqrt(std::max(0.0, (sum2 - n * a.sigma_px * a.sigma_px) / (n - 1)) / n) : 0;
        a.se_px = std::max(within, scatter);
        samples.push_back({d, a.sigma_px, a.se_px});
      }
      s->by_distance[e].push_back(a);
    }
    s->fit[e] = fitting::FitFocus(samples, o.focus);
    if (!s->fit[e].ok)
      s->notes.push_back(std::string(models::kEyeNames[e]) + " eye: no focus fit: " + s->fit[e].reason);
    else if (!s->fit[e].focus_found)
      s->notes.push_back(std::string(models::kEyeNames[e]) + " eye: no defocus over " +
                         FxOrInf(s->fit[e].min_distance_m, 2) + "-" + FxOrInf(s->fit[e].max_distance_m, 2) +
                         " m (defocus " + FxOrInf(s->fit[e].k_px_per_dioptre, 3) + " +- " +
                         FxOrInf(s->fit[e].k_sigma, 3) +
                         " px/D): the focus distance is not determined, everything measured is in focus");
  }
  for (const SharpnessRow& r : s->rows) {
    if (r.status == "ok") {
      ++s->num_ok;
    } else {
      ++s->num_failed;
      s->notes.push_back(r.image + " (" + models::kEyeNames[r.eye] + ", " + FxOrInf(r.distance_m, 2) +
                         " m): " + r.status + ": " + r.reason);
    }
  }
}

// sharpness_images: the edge blur per image.
reports::Table SharpnessImagesTable(const SharpnessStudy& s) {
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
  for (const SharpnessRow& r : s.rows) {
    const calib::EdgeSharpness& e = r.sharpness;
    const bool ok = r.status == "ok";
    images.rows.push_back({fs::path(r.image).filename().string(),
                           models::kEyeNames[r.eye],
                           FxOrInf(r.distance_m, 3),
                           r.status,
                           r.reason,
                           r.roi_source,
                           r.roi_source.empty() ? "" : std::to_string(e.roi.x),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.y),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.width),
                           r.roi_source.empty() ? "" : std::to_string(e.roi.height),
                           std::to_string(e.num_edges),
                           ok ? FxOrInf(e.blur_sigma_px, 4) : "",
                           ok ? FxOrInf(e.blur_sigma_se_px, 4) : "",
                           ok ? FxOrInf(e.laplacian_variance, 5) : "",
                           r.roi_source.empty() ? "" : FxOrInf(e.contrast, 1)});
  }
  return images;
}

// sharpness: the blur per distance and eye.
reports::Table SharpnessByDistanceTable(const SharpnessStudy& s) {
  reports::Table by{
      "sharpness",
      "Edge blur against distance (mean of the ok images, standard error; Laplacian variance / contrast^2)",
      {"eye", "distance_m", "ok", "images", "blur_sigma_px", "se_px", "fit_px", "laplacian_variance"},
      {}};
  for (int e = 0; e < 2; ++e)
    for (const SharpnessAtDistance& a : s.by_distance[e])
      by.rows.push_back({models::kEyeNames[e],
                         FxOrInf(a.distance_m, 3),
                         std::to_string(a.num_ok),
                         std::to_string(a.num_images),
                         a.num_ok ? FxOrInf(a.sigma_px, 4) : "",
                         a.num_ok ? FxOrInf(a.se_px, 4) : "",
                         s.fit[e].ok ? FxOrInf(s.fit[e].Predict(a.distance_m), 4) : "",
                         a.num_ok ? FxOrInf(a.laplacian_variance, 5) : ""});
  return by;
}

// sharpness_fit: the focus fit per eye.
reports::Table SharpnessFitTable(const SharpnessStudy& s) {
  reports::Table fit{
      "sharpness_fit",
      "Focus and depth of field per eye: sigma(d)^2 = s0^2 + k^2 (1/d - 1/focus)^2; depth of field where the blur "
      "is at most " +
          FxOrInf(s.fit[0].dof_blur_ratio, 3) + " x s0 (sharpness within " +
          FxOrInf(100 / std::max(1.0, s.fit[0].dof_blur_ratio), 0) + " % of its best)",
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
    auto z = [](double v, double truth, double sg) { return sg > 0 ? FxOrInf((v - truth) / sg, 2) : ""; };
    fit.rows.push_back({eye, "in-focus blur s0", FxOrInf(f.s0_px, 3), FxOrInf(f.s0_sigma_px, 3), "px", "", ""});
    fit.rows.push_back({eye,
                        "defocus k",
                        FxOrInf(f.k_px_per_dioptre, 3),
                        FxOrInf(f.k_sigma, 3),
                        "px/D",
                        t ? FxOrInf(s.truth->k_px_per_dioptre[e], 3) : "",
                        t ? z(f.k_px_per_dioptre, s.truth->k_px_per_dioptre[e], f.k_sigma) : ""});
    if (f.focus_found) {
      fit.rows.push_back({eye,
                          "focus",
                          FxOrInf(f.focus_dioptre, 3),
                          FxOrInf(f.focus_dioptre_sigma, 3),
                          "D",
                          t ? FxOrInf(1 / s.truth->focus_m, 3) : "",
                          t ? z(f.focus_dioptre, 1 / s.truth->focus_m, f.focus_dioptre_sigma) : ""});
      fit.rows.push_back({eye,
                          "focus distance",
                          FxOrInf(f.focus_m, 3),
                          FxOrInf(f.focus_sigma_m, 3),
                          "m",
                          t ? FxOrInf(s.truth->focus_m, 3) : "",
                          ""});
      fit.rows.push_back(
          {eye, "depth of field, near", FxOrInf(f.dof_near_m, 3), FxOrInf(f.dof_near_sigma_m, 3), "m", "", ""});
      // A far limit beyond the measured range is an extrapolation: said so, not given a number.
      if (f.dof_far_m > f.max_distance_m)
        fit.rows.push_back(
            {eye,
             "depth of field, far",
             "beyond " + FxOrInf(f.max_distance_m, 2),
             "",
             "m",
             "",
             std::isfinite(f.dof_far_m) ? "extrapolated: " + FxOrInf(f.dof_far_m, 1) + " m" : "to infinity"});
      else
        fit.rows.push_back(
            {eye, "depth of field, far", FxOrInf(f.dof_far_m, 3), FxOrInf(f.dof_far_sigma_m, 3), "m", "", ""});
    } else {
      fit.rows.push_back({eye,
                          "focus",
                          "not determined",
                          "",
                          "",
                          t ? FxOrInf(1 / s.truth->focus_m, 3) : "",
                          "no defocus over the measured range"});
      fit.rows.push_back({eye,
                          "depth of field",
                          "at least " + FxOrInf(f.dof_near_m, 2) + "-" + FxOrInf(f.dof_far_m, 2),
                          "",
                          "m",
                          "",
                          ""});
    }
    fit.rows.push_back({eye, "chi2/dof", FxOrInf(f.chi2_per_dof, 2), "", "", "", ""});
  }
  return fit;
}

// The figure: measured blur with 2 se bars, the fit, per eye.
reports::Figure SharpnessFigure(const SharpnessStudy& s) {
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
    for (const SharpnessAtDistance& a : s.by_distance[e])
      if (a.num_ok) pts.rows.push_back({a.distance_m, a.sigma_px, a.se_px});
    if (!pts.rows.empty()) fig.series.push_back(pts);
    const fitting::FocusFit& f = s.fit[e];
    if (f.ok) {
      reports::Series line{std::string(models::kEyeNames[e]) + " fit" +
                               (f.focus_found ? ", focus " + FxOrInf(f.focus_m, 2) + " m" : ", no defocus found"),
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
    for (const SharpnessAtDistance& a : s.by_distance[e])
      lo = std::min(lo, a.distance_m), hi = std::max(hi, a.distance_m);
  if (hi > lo) {
    fig.settings.push_back("set xrange [" + FxOrInf(0.85 * lo, 4) + ":" + FxOrInf(1.15 * hi, 4) + "]");
    std::string tics;  // a log axis over less than a decade needs its own labels
    for (const double t : {0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0})
      if (t >= 0.85 * lo && t <= 1.15 * hi) tics += (tics.empty() ? "" : ", ") + io::SignificantText(t, 3);
    if (!tics.empty()) fig.settings.push_back("set xtics (" + tics + ")");
  }
  // The depth of field's near limit per eye (dashed), where the fit found a focus.
  for (int e = 0; e < 2; ++e)
    if (s.fit[e].ok && s.fit[e].focus_found && s.fit[e].dof_near_m > 0.85 * lo && s.fit[e].dof_near_m < 1.15 * hi)
      fig.settings.push_back("set arrow from " + FxOrInf(s.fit[e].dof_near_m, 4) + ", graph 0 to " +
                             FxOrInf(s.fit[e].dof_near_m, 4) + ", graph 1 nohead dt 2 lw 1.5 lc rgb '" + colour[e] +
                             "'");
  fig.key = "top right";
  fig.caption =
      "Gaussian-equivalent edge blur per eye (mean over the ok images, bars +-2 standard errors) and the thin-lens "
      "fit; "
      "dashed: the near limit of the depth of field (blur <= " +
      FxOrInf(s.fit[0].dof_blur_ratio, 2) + " x the in-focus blur).";
  return fig;
}

// The report page: the figure (or why not), the fit and distance tables, the notes, every image.
std::string SharpnessPageHtml(const SharpnessStudy& s,
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

SharpnessStudy MeasureSharpnessDataset(const std::string& dir, const SharpnessOptions& o) {
  SharpnessStudy s;
  s.source = dir;
  const nlohmann::json manifest = protocols::ReadManifest(dir);
  const models::RobotConfig config = RobotConfigFromManifest(manifest, dir + "/manifest.json");
  // The protocol's chessboard (its size gives the "board fills the view" distance).
  calib::TargetDefinition board;
  bool have_board = false;
  if (manifest.contains("protocols"))
    for (const auto& p : manifest["protocols"]) {
      const protocols::Protocol proto = protocols::ParseProtocolYaml(p.value("text", ""), p.value("file", dir));
      if (auto it = proto.targets.find(proto.target);
          it != proto.targets.end() && it->second.kind == calib::TargetKind::kChessboard) {
        board = it->second;
        have_board = true;
      }
    }
  if (!have_board)
    throw std::runtime_error(dir + "/manifest.json: the sharpness study needs a protocol whose target is a chessboard");
  // A board the runner placed in a virtual scene stands at distance_m from the neck axis
  // (placements.csv, base frame); the lens is ahead of it by the eye centre's offset plus the
  // camera's offset from the eye's rotation centre. Boards a person placed are at the distance
  // the prompt asked for and the person measured: from the lens.
  double ahead_m[2] = {kNominalCameraAheadM, kNominalCameraAheadM};
  std::string ahead_source = "the nominal Owl head";
  if (manifest.contains("sim") && manifest["sim"].contains("truth_json") &&
      manifest["sim"]["truth_json"].contains("robot_truth")) {
    const nlohmann::json& t = manifest["sim"]["truth_json"]["robot_truth"];
    SharpnessTruth truth;
    truth.aperture_mm = t["stream"].value("aperture_mm", 0.0);
    truth.focus_m = t["stream"].value("focus_m", 0.0);
    for (int e = 0; e < 2; ++e)
      truth.k_px_per_dioptre[e] =
          truth.aperture_mm * 1e-3 * t["cameras"][models::kEyeNames[e]]["params"][0].get<double>() / 4;
    if (truth.aperture_mm > 0) s.truth = truth;
    for (int e = 0; e < 2; ++e) {
      const nlohmann::json& g = t["geometry"][models::kEyeNames[e]];
      ahead_m[e] = g["centre_in_head_m"][2].get<double>() - g["cam_from_eye"]["t_m"][2].get<double>();
    }
    ahead_source = "the virtual Owl's head";
  }
  const std::vector<protocols::PlacementRecord> placements = protocols::ReadPlacementsCsv(dir);
  std::map<std::pair<int64_t, int>, std::vector<Eigen::Vector2d>> corners;
  if (fs::exists(dir + "/observations.csv"))
    for (const calib::CornerObservation& c : calib::ReadObservationsCsv(dir + "/observations.csv"))
      corners[{c.frame_index, c.eye}].push_back(c.pixel);
  std::map<int, std::string> kind_of;
  for (const protocols::StepRecord& r : protocols::ReadStepsCsv(dir)) kind_of[r.step_index] = r.kind;
  const double focal_px = protocols::NominalFocalPx(config);
  const Eigen::Vector4d extent = board.Extent();
  const double board_w_m = extent[1] - extent[0] + 2 * board.square_m;  // with the white margin
  for (const protocols::FrameRecord& f : protocols::ReadFramesCsv(dir)) {
    if (f.step_index < 0 || f.placement_index < 0 || f.placement_index >= int(placements.size())) continue;
    if (kind_of.count(f.step_index) == 0 || kind_of[f.step_index] != "capture") continue;  // moves, placements
    const protocols::PlacementRecord& pl = placements[size_t(f.placement_index)];
    const cv::Mat frame = cv::imdecode(protocols::ReadFrameJpeg(dir, f.frame_index), cv::IMREAD_COLOR);
    if (frame.empty()) throw std::runtime_error(protocols::FramePath(dir, f.frame_index) + ": not a decodable JPEG");
    cv::Mat eyes[2];
    calib::SplitStereoFrame(frame, config.mirror_stream, config.swap_eyes, &eyes[0], &eyes[1]);
    for (int e = 0; e < 2; ++e) {
      const double d = pl.source == "scene" ? pl.distance_m - ahead_m[e] : pl.distance_m;
      SharpnessRow row;
      row.image = protocols::FramePath(dir, f.frame_index);
      row.frame_index = f.frame_index;
      row.eye = e;
      row.distance_m = d;
      const auto it = corners.find({f.frame_index, e});
      // The squares' size in the image: nominal focal length over the distance (the detected
      // corners would say the same within the board's tilt).
      const double square_px = focal_px * board.square_m / d;
      if (it != corners.end() && it->second.size() >= 4) {
        row.roi_source = "detected board";
        Measure(&row, eyes[e], BoardBox(it->second, eyes[e].size()), o, square_px);
      } else if (focal_px * board_w_m / d >= eyes[e].cols) {
        row.roi_source = "board fills the view";
        const cv::Size sz = eyes[e].size();
        Measure(&row, eyes[e], cv::Rect(sz.width / 4, sz.height / 4, sz.width / 2, sz.height / 2), o, square_px);
      } else {
        // Not detected while recording (its quick check gives up on small, low-contrast
        // boards): the full search of every command (classic, then sb).
        const calib::TargetDetection det = calib::DetectTarget(eyes[e], board, calib::DetectorOptions());
        if (det.found) {
          row.roi_source = "detected board";
          Measure(&row, eyes[e], BoardBox(det.pixels, eyes[e].size()), o, square_px);
        } else {
          row.status = "no target";
          row.reason =
              "the chessboard was not found (classic and sector-based detectors) and does not fill the view at " +
              FxOrInf(d, 2) + " m";
        }
      }
      s.rows.push_back(row);
    }
  }
  if (s.rows.empty())
    throw std::runtime_error(dir + ": no capture frames with a placement (is this a sharpness recording?)");
  for (const protocols::PlacementRecord& pl : placements)
    if (pl.source == "scene") {
      s.notes.push_back("distances are from the lens: the scene's placements (from the neck axis) less " +
                        FxOrInf(1e3 * ahead_m[0], 1) + " / " + FxOrInf(1e3 * ahead_m[1], 1) +
                        " mm (left / right), from " + ahead_source);
      break;
    }
  Summarise(&s, o);
  return s;
}

std::vector<SharpnessPair> ReadSharpnessPairsCsv(const std::string& path) {
  const fs::path base = fs::path(path).parent_path();
  std::vector<SharpnessPair> out;
  for (const evaluation::RangeTruthRow& r : evaluation::ReadRangeTruthCsv(path)) {
    if (!std::isfinite(r.distance_m))
      throw std::runtime_error(r.where + ": the distance is blank (sharpness needs every distance)");
    SharpnessPair p;
    p.left = fs::path(r.left).is_absolute() ? r.left : (base / r.left).string();
    p.right = fs::path(r.right).is_absolute() ? r.right : (base / r.right).string();
    p.distance_m = r.distance_m;
    p.roi = r.roi;
    out.push_back(p);
  }
  if (out.empty()) throw std::runtime_error(path + ": no image pairs");
  return out;
}

SharpnessStudy MeasureSharpnessPairs(const std::vector<SharpnessPair>& pairs,
                                     const std::string& source,
                                     const SharpnessOptions& o) {
  SharpnessStudy s;
  s.source = source;
  for (const SharpnessPair& p : pairs) {
    for (int e = 0; e < 2; ++e) {
      SharpnessRow row;
      row.image = e == 0 ? p.left : p.right;
      row.eye = e;
      row.distance_m = p.distance_m;
      const cv::Mat img = cv::imread(row.image, cv::IMREAD_GRAYSCALE);
      if (img.empty()) {
        row.status = "unreadable";
        row.reason = "not an image OpenCV can read";
      } else {
        row.roi_source = p.roi.area() > 0 ? "given" : "default window";
        Measure(&row, img, p.roi.area() > 0 ? p.roi : DefaultWindow(p.distance_m, img.size()), o);
      }
      s.rows.push_back(row);
    }
  }
  Summarise(&s, o);
  return s;
}

nlohmann::json SharpnessStudyJson(const SharpnessStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["num_ok"] = s.num_ok;
  j["num_failed"] = s.num_failed;
  j["notes"] = s.notes;
  for (int e = 0; e < 2; ++e) {
    const fitting::FocusFit& f = s.fit[e];
    nlohmann::json eye;
    for (const SharpnessAtDistance& a : s.by_distance[e])
      eye["by_distance"].push_back({{"distance_m", a.distance_m},
                                    {"num_ok", a.num_ok},
                                    {"num_images", a.num_images},
                                    {"blur_sigma_px", a.num_ok ? io::JsonNumber(a.sigma_px) : nullptr},
                                    {"blur_sigma_se_px", a.num_ok ? io::JsonNumber(a.se_px) : nullptr},
                                    {"laplacian_variance", a.num_ok ? io::JsonNumber(a.laplacian_variance) : nullptr}});
    eye["fit"] = {{"ok", f.ok},
                  {"reason", f.reason},
                  {"focus_found", f.focus_found},
                  {"in_focus_blur_px", io::JsonNumber(f.s0_px)},
                  {"in_focus_blur_sigma_px", io::JsonNumber(f.s0_sigma_px)},
                  {"defocus_px_per_dioptre", io::JsonNumber(f.k_px_per_dioptre)},
                  {"defocus_sigma", io::JsonNumber(f.k_sigma)},
                  {"focus_dioptre", f.focus_found ? io::JsonNumber(f.focus_dioptre) : nullptr},
                  {"focus_dioptre_sigma", f.focus_found ? io::JsonNumber(f.focus_dioptre_sigma) : nullptr},
                  {"focus_m", f.focus_found ? io::JsonNumber(f.focus_m) : nullptr},
                  {"dof_blur_ratio", f.dof_blur_ratio},
                  {"dof_near_m", io::JsonNumber(f.dof_near_m)},
                  {"dof_near_sigma_m", io::JsonNumber(f.dof_near_sigma_m)},
                  {"dof_far_m", io::JsonNumber(f.dof_far_m)},  // null = infinity
                  {"dof_far_sigma_m", io::JsonNumber(f.dof_far_sigma_m)},
                  {"chi2_per_dof", io::JsonNumber(f.chi2_per_dof)}};
    j["eyes"][models::kEyeNames[e]] = eye;
  }
  if (s.truth) {
    j["truth"] = {{"aperture_mm", s.truth->aperture_mm},
                  {"focus_m", s.truth->focus_m},
                  {"defocus_px_per_dioptre", {s.truth->k_px_per_dioptre[0], s.truth->k_px_per_dioptre[1]}}};
  }
  return j;
}

std::string WriteSharpnessStudy(const SharpnessStudy& s, const std::string& out, bool draw) {
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

  nlohmann::json j = SharpnessStudyJson(s);
  reports::WriteTextFile(out + "/sharpness.json", j.dump(2) + "\n");
  const std::string html = SharpnessPageHtml(s, images, by, fit, fig, ff);
  const std::string page = out + "/report/index.html";
  reports::WriteTextFile(page, html);
  return page;
}

}  // namespace owlcal::pipeline
