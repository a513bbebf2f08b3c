#include "reports/catch_up_study_page.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/statistics.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {

namespace fs = std::filesystem;

}  // namespace

std::string WriteCatchUpStudy(const evaluation::CatchUpStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");
  reports::Table trials{"catch_up_trials",
                        "Catch-up trials, one per target speed: catch-up saccades, RMS retinal error while the target "
                        "moved (measured and true), mean |error| before and after the saccades, median response",
                        {"trial",
                         "speed_deg_per_s",
                         "direction",
                         "status",
                         "reason",
                         "frames",
                         "found",
                         "saccades",
                         "rms_error_deg",
                         "true_rms_error_deg",
                         "mean_error_before_deg",
                         "mean_error_after_deg",
                         "median_response_ms"},
                        {}};
  for (const evaluation::CatchUpTrial& t : s.trials)
    trials.rows.push_back({std::to_string(t.trial),
                           evaluation::Fx(t.speed_deg_per_s, 2),
                           std::to_string(t.direction),
                           t.status,
                           t.reason,
                           std::to_string(t.frames),
                           std::to_string(t.found),
                           std::to_string(t.saccades),
                           evaluation::Fx(t.rms_error_deg, 3),
                           evaluation::Fx(t.true_rms_error_deg, 3),
                           evaluation::Fx(t.mean_before_deg, 3),
                           evaluation::Fx(t.mean_after_deg, 3),
                           evaluation::Fx(t.median_response_ms, 1)});
  reports::Table sacc{"catch_up_saccades",
                      "Catch-up saccades, one row per saccade: retinal error in the frame that triggered it and in the "
                      "first frame used after it (measured and true), response = command to the first frame with "
                      "less than half the error",
                      {"trial",
                       "speed_deg_per_s",
                       "k",
                       "t_s",
                       "error_before_deg",
                       "error_after_deg",
                       "true_error_before_deg",
                       "true_error_after_deg",
                       "response_ms"},
                      {}};
  for (const evaluation::CatchUpSaccade& c : s.saccades)
    sacc.rows.push_back({std::to_string(c.trial),
                         evaluation::Fx(c.speed_deg_per_s, 2),
                         std::to_string(c.k),
                         evaluation::Fx(c.t_s, 4),
                         evaluation::Fx(c.error_before_deg, 3),
                         evaluation::Fx(c.error_after_deg, 3),
                         evaluation::Fx(c.true_error_before_deg, 3),
                         evaluation::Fx(c.true_error_after_deg, 3),
                         evaluation::Fx(c.response_ms, 1)});
  reports::Table frames{"catch_up_frames",
                        "Catch-up frames, one row per frame (t_s: arrival from the trial's start; error: the target's "
                        "horizontal angle in the camera; action: what the controller did)",
                        {evaluation::kCatchUpFrameColumns.begin(), evaluation::kCatchUpFrameColumns.end()},
                        {}};
  for (const evaluation::CatchUpFrame& f : s.frames)
    frames.rows.push_back({std::to_string(f.trial),
                           evaluation::Fx(f.speed_deg_per_s, 2),
                           std::to_string(f.direction),
                           std::to_string(f.k),
                           evaluation::Fx(f.t_s, 6),
                           evaluation::Fx(f.target_az_deg, 4),
                           std::to_string(f.cmd_us),
                           f.found ? "1" : "0",
                           evaluation::Fx(f.x_px, 3),
                           evaluation::Fx(f.error_deg, 4),
                           evaluation::Fx(f.true_error_deg, 4),
                           f.action});
  reports::WriteTable(trials, out + "/tables");
  reports::WriteTable(sacc, out + "/tables");
  reports::WriteTextFile(out + "/tables/catch_up_frames.csv", reports::ToCsv(frames));

  // The fastest trial with frames.
  const evaluation::CatchUpTrial* shown = nullptr;
  for (const evaluation::CatchUpTrial& t : s.trials)
    if (t.frames > 0 && (!shown || t.speed_deg_per_s > shown->speed_deg_per_s)) shown = &t;
  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  if (shown) {
    reports::Figure tr;
    tr.name = "catch_up_trace";
    tr.title = "Pursuit of a target at " + evaluation::Fx(shown->speed_deg_per_s, 0) + " deg/s: retinal error";
    tr.xlabel = "time from the trial's start (frame arrival) [s]";
    tr.ylabel = "target's horizontal angle in the camera [deg]";
    reports::Series m{"measured from the frames", "lines lw 2 lc rgb '#1f77b4'", "1:2", {"t_s", "error_deg"}, {}};
    reports::Series t{
        "truth at the exposure", "lines dt 2 lw 1.5 lc rgb '#444444'", "1:2", {"t_s", "true_error_deg"}, {}};
    reports::Series c{"catch-up saccade sent", "points pt 7 ps 1.8 lc rgb '#d62728'", "1:2", {"t_s", "error_deg"}, {}};
    for (const evaluation::CatchUpFrame& f : s.frames) {
      if (f.trial != shown->trial) continue;
      if (std::isfinite(f.error_deg)) m.rows.push_back({f.t_s, f.error_deg});
      if (std::isfinite(f.true_error_deg)) t.rows.push_back({f.t_s, f.true_error_deg});
      if (f.action == "saccade" && std::isfinite(f.error_deg)) c.rows.push_back({f.t_s, f.error_deg});
    }
    tr.series.push_back(m);
    if (!t.rows.empty()) tr.series.push_back(t);
    if (!c.rows.empty()) tr.series.push_back(c);
    // Headroom above the curves for the legend (below the plot it hid the x label).
    tr.settings = {"set grid", "set offsets 0, 0, graph 0.35, graph 0.05"};
    tr.key = "top center horizontal maxrows 2";
    tr.caption = "The target's angle from the eye's optical axis while it moves at " +
                 evaluation::Fx(shown->speed_deg_per_s, 0) +
                 " deg/s: the P-loop pursuit falls behind, and each catch-up "
                 "saccade (red dots: the frame that triggered it) brings the error back; each leads the target by "
                 "its estimated speed, so one sent as the target stops at the end of its sweep overshoots. " +
                 std::to_string(shown->saccades) + " catch-up saccades; RMS error " +
                 evaluation::Fx(shown->rms_error_deg, 2) + " deg while the target moved.";
    figs.push_back(reports::WriteFigure(tr, out + "/figures", draw));
    drawn.push_back(tr);
  }
  reports::WriteTextFile(out + "/catch_up.json", evaluation::CatchUpStudyJson(s).dump(2) + "\n");
  reports::ExperimentPage page;
  page.title = "catch-up saccades";
  page.heading = "Catch-up saccades";
  page.intro_html = std::string(
      "Source: " + reports::HtmlEscape(s.source) + ". Eye on the " + reports::HtmlEscape(s.map) + ". " +
      std::to_string(s.num_ok) + " of " + std::to_string(s.num_trials) +
      " trials ok. The target moves at constant angular speed; the eye pursues it with a P loop on the map and makes a "
      "catch-up saccade when the retinal error passes the threshold (protocols/catch_up_step.h).");
  page.figures = drawn;
  page.files = figs;
  page.tables_html = reports::ToHtml(trials) + "\n";
  page.notes = s.notes;
  page.after_notes_html = reports::ToHtml(sacc) + "\n<p>Every frame: tables/catch_up_frames.csv.</p>\n";
  return reports::WriteExperimentPage(page, out);
}

}  // namespace owlcal::reports
