// The tracking study's page (WriteTrackingStudy, evaluation/tracking_study.h): the summary, lost,
// salience and frame tables, the error and salience-map figures, and the page.
#include "reports/tracking_study_page.h"

#include <algorithm>
#include <filesystem>
#include <tuple>

#include "evaluation/study_cells.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {
namespace fs = std::filesystem;

constexpr double kErrorPlotCapPx = 5;  // the error figure's top; larger errors are drawn there

// track_summary: per tracker and eye.
reports::Table TrackSummaryTable(const evaluation::TrackingStudy& s) {
  reports::Table summary{
      "track_summary",
      "Tracking per tracker and eye against the virtual Owl's truth: frames, lost (no position; lost in view = the "
      "target was in the image), reacquired, positions given with the target out of view, and the pixel error "
      "against the target's true pixel over the frames with a position and the target in view (off target: error > " +
          evaluation::Fx(evaluation::kOffTargetPx, 0) + " px)",
      {"tracker",
       "eye",
       "frames",
       "found",
       "lost",
       "reacquired",
       "in_view",
       "lost_in_view",
       "found_out_of_view",
       "error_frames",
       "rms_px",
       "max_px",
       "off_target"},
      {}};
  for (const evaluation::TrackerSummary& t : s.summaries)
    summary.rows.push_back({t.tracker,
                            models::kEyeNames[t.eye],
                            std::to_string(t.num_frames),
                            std::to_string(t.num_found),
                            std::to_string(t.num_lost),
                            std::to_string(t.num_reacquired),
                            std::to_string(t.num_in_view),
                            std::to_string(t.num_lost_in_view),
                            std::to_string(t.num_found_out_of_view),
                            std::to_string(t.num_errors),
                            evaluation::Fx(t.rms_px, 3),
                            evaluation::Fx(t.max_px, 3),
                            std::to_string(t.num_off_target)});
  return summary;
}

// track_lost: frames per reason the target was lost.
reports::Table TrackLostTable(const evaluation::TrackingStudy& s) {
  reports::Table lost{"track_lost",
                      "Why each tracker lost the target: frames per reason (# stands for the numbers in the reason)",
                      {"tracker", "eye", "frames", "reason"},
                      {}};
  for (const evaluation::TrackerSummary& t : s.summaries)
    for (const auto& [reason, n] : t.lost_reasons)
      lost.rows.push_back({t.tracker, models::kEyeNames[t.eye], std::to_string(n), reason});
  return lost;
}

// salience_candidates: the right eye's candidates, strongest first.
reports::Table SalienceTable(const evaluation::TrackingStudy& s) {
  reports::Table sal{"salience_candidates",
                     "Salience candidates of the right eye, strongest first: pixel, score and its channels, the scene "
                     "object it lies on (truth) with the distance to that object's centre (to the nearest object when "
                     "it lies on none), and the right eye's fixation of it with the LK tracker",
                     {evaluation::kSalienceRowColumns.begin(), evaluation::kSalienceRowColumns.end()},
                     {}};
  for (const evaluation::SalienceRow& c : s.salience)
    sal.rows.push_back({std::to_string(c.rank),
                        evaluation::Fx(c.x_px, 2),
                        evaluation::Fx(c.y_px, 2),
                        evaluation::Fx(c.score, 4),
                        evaluation::Fx(c.intensity, 4),
                        evaluation::Fx(c.colour, 4),
                        evaluation::Fx(c.orientation, 4),
                        c.object,
                        evaluation::Fx(c.object_distance_px, 2),
                        evaluation::Fx(c.object_radius_px, 2),
                        c.fix_status,
                        c.fix_reason,
                        std::to_string(c.fix_iterations),
                        evaluation::Fx(c.fix_dx_px, 3),
                        evaluation::Fx(c.fix_dy_px, 3),
                        c.fixated_object,
                        evaluation::Fx(c.fixated_distance_px, 2)});
  return sal;
}

// track_frames: one row per frame, eye and tracker.
reports::Table TrackFramesTable(const evaluation::TrackingStudy& s) {
  reports::Table frames{"track_frames",
                        "Tracking frames: one row per frame, eye and tracker (empty = no position or no truth)",
                        {"step_index",
                         "phase",
                         "k",
                         "t_s",
                         "eye",
                         "tracker",
                         "pan_cmd_us",
                         "tilt_cmd_us",
                         "status",
                         "found",
                         "x_px",
                         "y_px",
                         "true_x_px",
                         "true_y_px",
                         "true_in_view",
                         "error_px",
                         "reason"},
                        {}};
  for (const evaluation::TrackFrame& f : s.frames)
    frames.rows.push_back({std::to_string(f.step_index),
                           f.phase,
                           std::to_string(f.k),
                           evaluation::Fx(f.t_s, 6),
                           models::kEyeNames[f.eye],
                           f.tracker,
                           std::to_string(f.pan_cmd_us),
                           std::to_string(f.tilt_cmd_us),
                           f.status,
                           f.found ? "1" : "0",
                           evaluation::Fx(f.x_px, 3),
                           evaluation::Fx(f.y_px, 3),
                           evaluation::Fx(f.true_x_px, 3),
                           evaluation::Fx(f.true_y_px, 3),
                           f.true_in_view < 0 ? "" : std::to_string(f.true_in_view),
                           evaluation::Fx(f.error_px, 4),
                           f.reason});
  return frames;
}

// track_error: each tracker's pixel error against the truth, and where it lost the target.
reports::Figure TrackErrorFigure(const evaluation::TrackingStudy& s) {
  const char* colours[2][2] = {{"#1f77b4", "#6baed6"}, {"#d62728", "#fc9272"}};  // [tracker][eye]
  reports::Figure ef;
  ef.name = "track_error";
  ef.title = "Tracked pixel against the target's true pixel";
  ef.xlabel = "time from the first frame [s]";
  ef.ylabel = "pixel error |tracked - true| [px]";
  int ti = 0;
  std::vector<std::string> trackers;
  for (const evaluation::TrackerSummary& t : s.summaries)
    if (std::find(trackers.begin(), trackers.end(), t.tracker) == trackers.end()) trackers.push_back(t.tracker);
  double lost_y = kErrorPlotCapPx * 1.08;
  for (const std::string& tr : trackers) {
    for (int e = 0; e < 2; ++e) {
      const evaluation::TrackerSummary* ts = s.Find(tr, e);
      if (!ts) continue;
      const char* c = colours[std::min(ti, 1)][e];
      reports::Series err{tr + ", " + models::kEyeNames[e] + " eye (RMS " + evaluation::Fx(ts->rms_px, 2) + " px)",
                          std::string("points pt 7 ps 0.6 lc rgb '") + c + "'",
                          "1:2",
                          {"t_s", "error_px"},
                          {}};
      reports::Series miss{tr + ", " + models::kEyeNames[e] + " eye: lost",
                           std::string("points pt ") + (ti == 0 ? "2" : "6") + " ps 0.8 lc rgb '" + c + "'",
                           "1:2",
                           {"t_s", "lost_marker"},
                           {}};
      for (const evaluation::TrackFrame& f : s.frames) {
        if (f.tracker != tr || f.eye != e) continue;
        if (f.found && std::isfinite(f.error_px) && f.true_in_view == 1)
          err.rows.push_back({f.t_s, std::min(f.error_px, kErrorPlotCapPx)});
        else if (!f.found)
          miss.rows.push_back({f.t_s, lost_y + 0.12 * (2 * ti + e)});
      }
      if (!err.rows.empty()) ef.series.push_back(err);
      if (!miss.rows.empty()) ef.series.push_back(miss);
    }
    ++ti;
  }
  ef.settings = {"set grid",
                 "set xrange [0:*]",
                 "set yrange [0:" + evaluation::Fx(kErrorPlotCapPx * 1.08 + 0.12 * 4 + 0.1, 2) + "]"};
  // The phases: where the eyes turn the target out of view and back.
  double leave_t = NAN, return_t = NAN;
  for (const evaluation::TrackFrame& f : s.frames) {
    if (f.phase == "leave" && !std::isfinite(leave_t)) leave_t = f.t_s;
    if (f.phase == "return" && !std::isfinite(return_t)) return_t = f.t_s;
  }
  for (const auto& [t, label, y] :
       {std::tuple{leave_t, "eyes turn away", "0.55"}, std::tuple{return_t, "eyes turn back", "0.4"}})
    if (std::isfinite(t)) {
      ef.settings.push_back("set arrow from " + evaluation::Fx(t, 3) + ", graph 0 to " + evaluation::Fx(t, 3) +
                            ", graph 1 nohead dt 2 lc rgb '#555555'");
      ef.settings.push_back("set label '" + std::string(label) + "' at " + evaluation::Fx(t + 0.03, 3) + ", graph " +
                            y + " tc rgb '#555555'");
    }
  ef.key = "top left box opaque";  // below, it covered the x label; top left holds no data (errors < 1 px
                                   // there, lost markers at the top right)
  ef.caption =
      "Pixel error of each tracker against the target's true projected pixel per frame with the target in "
      "view (dashed lines: the eyes turn the target out of view and back), errors above " +
      evaluation::Fx(kErrorPlotCapPx, 0) + " px drawn at " + evaluation::Fx(kErrorPlotCapPx, 0) +
      " px; markers above the plot area's " + evaluation::Fx(kErrorPlotCapPx, 0) +
      " px line are frames where the tracker reported the track lost (no position).";
  return ef;
}

// salience_map: the right eye's salience map and the candidates.
reports::Figure SalienceMapFigure(const evaluation::TrackingStudy& s) {
  reports::Figure sf;
  sf.name = "salience_map";
  sf.title = "Salience map of the right eye and the picked targets";
  sf.xlabel = "x [px]";
  sf.ylabel = "y [px]";
  reports::Series m{"", "image", "1:2:3", {"x_px", "y_px", "salience"}, {}};
  for (const auto& v : s.salience_map) m.rows.push_back({v[0], v[1], v[2]});
  sf.series.push_back(m);
  reports::Series on{
      "candidate on a scene object (truth)", "points pt 7 ps 1.8 lc rgb '#00cc44'", "1:2", {"x_px", "y_px"}, {}};
  reports::Series off{"candidate on no object", "points pt 2 ps 2 lw 2 lc rgb '#ff00ff'", "1:2", {"x_px", "y_px"}, {}};
  for (const evaluation::SalienceRow& c : s.salience) {
    (c.object.empty() ? off : on).rows.push_back({c.x_px, c.y_px});
    sf.settings.push_back("set label '" + std::to_string(c.rank) + "' at " + evaluation::Fx(c.x_px + 8, 1) + "," +
                          evaluation::Fx(c.y_px - 8, 1) + " front tc rgb 'white' font ',14'");
  }
  if (!on.rows.empty()) sf.series.push_back(on);
  if (!off.rows.empty()) sf.series.push_back(off);
  sf.settings.insert(sf.settings.begin(),
                     {"set yrange [479:0]",
                      "set xrange [0:639]",
                      "set size ratio -1",
                      "set cblabel 'salience [0-1]'",
                      "set palette gray"});
  sf.key = "below";
  sf.width_px = 900;
  sf.height_px = 760;
  sf.caption =
      "The right eye's salience map (Itti-Koch-style: intensity, colour and orientation channels, each a "
      "difference of Gaussians normalised by N(.)), with the candidates numbered by rank; " +
      std::to_string(s.num_on_object) + " of " + std::to_string(s.salience.size()) +
      " lie on a scene object by the truth.";
  return sf;
}

}  // namespace

std::string WriteTrackingStudy(const evaluation::TrackingStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");

  const reports::Table summary = TrackSummaryTable(s);
  const reports::Table lost = TrackLostTable(s);
  const reports::Table sal = SalienceTable(s);
  const reports::Table frames = TrackFramesTable(s);
  reports::WriteTable(summary, out + "/tables");
  reports::WriteTable(lost, out + "/tables");
  reports::WriteTable(sal, out + "/tables");
  reports::WriteTextFile(out + "/tables/track_frames.csv", reports::ToCsv(frames));

  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  if (s.has_truth && !s.frames.empty()) {
    const reports::Figure ef = TrackErrorFigure(s);
    if (!ef.series.empty()) {
      figs.push_back(reports::WriteFigure(ef, out + "/figures", draw));
      drawn.push_back(ef);
    }
  }
  if (!s.salience_map.empty()) {
    const reports::Figure sf = SalienceMapFigure(s);
    figs.push_back(reports::WriteFigure(sf, out + "/figures", draw));
    drawn.push_back(sf);
  }

  reports::WriteTextFile(out + "/track.json", evaluation::TrackingStudyJson(s).dump(2) + "\n");

  reports::ExperimentPage page;
  page.title = "salience and tracking";
  page.heading = "Salience targets and tracking";
  page.intro_html = std::string(
      "Source: " + reports::HtmlEscape(s.source) +
      ". A salience map of the right eye picks the next fixation targets and the right eye fixates each with a "
      "Lucas-Kanade tracker; then the eyes move through a figure of eight (and, when asked, turn until the target "
      "leaves the view and back) while the target is tracked in both eyes by the fixation locator and by "
      "Lucas-Kanade (pyramidal LK with a forward-backward check, protocols/track_step.h). Salience candidates on a "
      "scene object: " +
      std::to_string(s.num_on_object) + " of " + std::to_string(s.salience.size()) +
      "; fixated: " + std::to_string(s.num_fixated) + ".");
  page.figures = drawn;
  page.files = figs;
  page.tables_html = reports::ToHtml(summary) + "\n" + reports::ToHtml(lost) + "\n" +
                     (s.salience.empty() ? std::string() : reports::ToHtml(sal) + "\n");
  page.notes = s.notes;
  page.after_notes_html = "<p>Every frame: tables/track_frames.csv.</p>\n";
  return reports::WriteExperimentPage(page, out);
}

}  // namespace owlcal::reports
