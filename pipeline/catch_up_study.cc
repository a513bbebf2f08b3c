#include "pipeline/catch_up_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/statistics.h"
#include "pipeline/study_cells.h"
#include "protocols/dataset.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace {

// Measured and true retinal error further apart than this: the eye tracked something else.
constexpr double kOffTargetDeg = 2.0;
namespace fs = std::filesystem;

double Mean(const std::vector<double>& v) {
  if (v.empty()) return NAN;
  double s = 0;
  for (double x : v) s += x;
  return s / v.size();
}

}  // namespace

CatchUpStudy EvaluateCatchUpDataset(const std::string& dir) {
  CatchUpStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/catch_up.csv", trials_csv = dir + "/catch_up_trials.csv";
  if (!fs::exists(trials_csv))
    throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a catch-up dataset?)");
  const calib::CsvTable tt = protocols::ReadAppendedCsv(trials_csv);
  tt.RequireColumns(
      {"trial", "speed_deg_per_s", "direction", "frames", "found", "saccades", "map", "status", "reason"});
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    CatchUpTrial t;
    t.trial = tt.Int(r, "trial", 0, 1000000);
    t.speed_deg_per_s = tt.Number(r, "speed_deg_per_s", 0, 1000);
    t.direction = tt.Int(r, "direction", -1, 1);
    t.frames = tt.Int(r, "frames", 0, 10000000);
    t.found = tt.Int(r, "found", 0, 10000000);
    t.saccades = tt.Int(r, "saccades", 0, 10000000);
    t.status = tt.Text(r, "status");
    t.reason = tt.Text(r, "reason");
    if (s.map.empty()) s.map = tt.Text(r, "map");
    s.trials.push_back(t);
  }
  if (fs::exists(frames_csv)) {
    const calib::CsvTable ft = protocols::ReadAppendedCsv(frames_csv);
    ft.RequireColumns({"trial",
                       "speed_deg_per_s",
                       "direction",
                       "k",
                       "t_s",
                       "target_az_deg",
                       "cmd_us",
                       "found",
                       "x_px",
                       "error_deg",
                       "true_error_deg",
                       "action"});
    for (size_t r = 0; r < ft.NumRows(); ++r) {
      CatchUpFrame f;
      f.trial = ft.Int(r, "trial", 0, 1000000);
      f.speed_deg_per_s = ft.Number(r, "speed_deg_per_s", 0, 1000);
      f.direction = ft.Int(r, "direction", -1, 1);
      f.k = ft.Int(r, "k", 0, 10000000);
      f.t_s = ft.Number(r, "t_s", -10, 1e6);
      f.target_az_deg = ft.Number(r, "target_az_deg", -360, 360);
      f.cmd_us = ft.Int(r, "cmd_us", 0, 5000);
      f.found = ft.Int(r, "found", 0, 1) == 1;
      f.x_px = Opt(ft, r, "x_px");
      f.error_deg = Opt(ft, r, "error_deg");
      f.true_error_deg = Opt(ft, r, "true_error_deg");
      f.action = ft.Text(r, "action");
      s.has_truth |= std::isfinite(f.true_error_deg);
      s.frames.push_back(f);
    }
  }
  std::stable_sort(s.frames.begin(), s.frames.end(), [](const CatchUpFrame& a, const CatchUpFrame& b) {
    return a.trial != b.trial ? a.trial < b.trial : a.k < b.k;
  });
  for (CatchUpTrial& t : s.trials) {
    std::vector<const CatchUpFrame*> fr;
    for (const CatchUpFrame& f : s.frames)
      if (f.trial == t.trial) fr.push_back(&f);
    if (fr.empty()) continue;
    const double az_end = fr.back()->target_az_deg;
    double ss = 0, tss = 0;
    int n = 0, tn = 0;
    std::vector<double> before, after, response;
    for (size_t i = 0; i < fr.size(); ++i) {
      const CatchUpFrame& f = *fr[i];
      if (std::abs(f.target_az_deg - az_end) > 1e-6) {  // the target still moving
        if (std::isfinite(f.error_deg)) ss += f.error_deg * f.error_deg, ++n;
        if (std::isfinite(f.true_error_deg)) tss += f.true_error_deg * f.true_error_deg, ++tn;
      }
      if (f.action != "saccade") continue;
      CatchUpSaccade c;
      c.trial = t.trial;
      c.k = f.k;
      c.speed_deg_per_s = t.speed_deg_per_s;
      c.t_s = f.t_s;
      c.error_before_deg = f.error_deg;
      c.true_error_before_deg = f.true_error_deg;
      for (size_t j = i + 1; j < fr.size(); ++j) {
        const CatchUpFrame& g = *fr[j];
        // After: the first frame the controller used (it may trigger the next saccade).
        if (!std::isfinite(c.error_after_deg) && g.action != "wait" && std::isfinite(g.error_deg)) {
          c.error_after_deg = g.error_deg;
          c.true_error_after_deg = g.true_error_deg;
        }
        if (g.action == "saccade") break;
        if (!std::isfinite(c.response_ms) && std::isfinite(g.error_deg) &&
            std::abs(g.error_deg) < 0.5 * std::abs(c.error_before_deg))
          c.response_ms = 1000 * (g.t_s - f.t_s);
      }
      before.push_back(std::abs(c.error_before_deg));
      if (std::isfinite(c.error_after_deg)) after.push_back(std::abs(c.error_after_deg));
      if (std::isfinite(c.response_ms)) response.push_back(c.response_ms);
      s.saccades.push_back(c);
    }
    t.rms_error_deg = n ? std::sqrt(ss / n) : NAN;
    t.true_rms_error_deg = tn ? std::sqrt(tss / tn) : NAN;
    // With the truth (the virtual Owl): a trial whose measured retinal error leaves the true one
    // tracked something else (a wall blob where the disc should be) and is no pursuit of the target,
    // whatever its controller reported. The measured error goes through the maps' lens, so the two
    // differ by a few tenths of a degree on nominal maps; 2 deg is far outside that.
    std::vector<double> gap;
    for (const CatchUpFrame* f : fr)
      if (std::isfinite(f->error_deg) && std::isfinite(f->true_error_deg))
        gap.push_back(std::abs(f->error_deg - f->true_error_deg));
    const int off = int(std::count_if(gap.begin(), gap.end(), [](double g) { return g > kOffTargetDeg; }));
    if (t.status == "ok" && off >= 3) {
      t.status = "off target";
      t.reason = "the eye tracked something else: the measured retinal error left the truth by more than " +
                 Fx(kOffTargetDeg, 1) + " deg in " + std::to_string(off) + " of " + std::to_string(gap.size()) +
                 " frames (median " + Fx(models::Median(gap), 2) + ", up to " +
                 Fx(*std::max_element(gap.begin(), gap.end()), 1) + " deg)";
    }
    t.mean_before_deg = Mean(before);
    t.mean_after_deg = Mean(after);
    t.median_response_ms = response.empty() ? NAN : models::Median(response);
  }
  s.num_trials = int(s.trials.size());
  for (const CatchUpTrial& t : s.trials) {
    if (t.status == "ok")
      ++s.num_ok;
    else
      s.notes.push_back("trial " + std::to_string(t.trial) + " (" + Fx(t.speed_deg_per_s, 1) + " deg/s): " + t.status +
                        (t.reason.empty() ? "" : ": " + t.reason));
  }
  if (s.map.find("nominal") != std::string::npos)
    s.notes.insert(s.notes.begin(), "the eye moved on the robot file's NOMINAL maps (no calibration)");
  return s;
}

nlohmann::json CatchUpStudyJson(const CatchUpStudy& s) {
  nlohmann::json j = TrialStudyHeaderJson(s);
  j["trials"] = nlohmann::json::array();
  for (const CatchUpTrial& t : s.trials)
    j["trials"].push_back({{"trial", t.trial},
                           {"speed_deg_per_s", t.speed_deg_per_s},
                           {"direction", t.direction},
                           {"status", t.status},
                           {"reason", t.reason},
                           {"frames", t.frames},
                           {"found", t.found},
                           {"saccades", t.saccades},
                           {"rms_error_deg", io::JsonNumber(t.rms_error_deg)},
                           {"true_rms_error_deg", io::JsonNumber(t.true_rms_error_deg)},
                           {"mean_error_before_deg", io::JsonNumber(t.mean_before_deg)},
                           {"mean_error_after_deg", io::JsonNumber(t.mean_after_deg)},
                           {"median_response_ms", io::JsonNumber(t.median_response_ms)}});
  j["saccades"] = nlohmann::json::array();
  for (const CatchUpSaccade& c : s.saccades)
    j["saccades"].push_back({{"trial", c.trial},
                             {"k", c.k},
                             {"t_s", c.t_s},
                             {"error_before_deg", io::JsonNumber(c.error_before_deg)},
                             {"error_after_deg", io::JsonNumber(c.error_after_deg)},
                             {"response_ms", io::JsonNumber(c.response_ms)}});
  return j;
}

std::string WriteCatchUpStudy(const CatchUpStudy& s, const std::string& out, bool draw) {
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
  for (const CatchUpTrial& t : s.trials)
    trials.rows.push_back({std::to_string(t.trial),
                           Fx(t.speed_deg_per_s, 2),
                           std::to_string(t.direction),
                           t.status,
                           t.reason,
                           std::to_string(t.frames),
                           std::to_string(t.found),
                           std::to_string(t.saccades),
                           Fx(t.rms_error_deg, 3),
                           Fx(t.true_rms_error_deg, 3),
                           Fx(t.mean_before_deg, 3),
                           Fx(t.mean_after_deg, 3),
                           Fx(t.median_response_ms, 1)});
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
  for (const CatchUpSaccade& c : s.saccades)
    sacc.rows.push_back({std::to_string(c.trial),
                         Fx(c.speed_deg_per_s, 2),
                         std::to_string(c.k),
                         Fx(c.t_s, 4),
                         Fx(c.error_before_deg, 3),
                         Fx(c.error_after_deg, 3),
                         Fx(c.true_error_before_deg, 3),
                         Fx(c.true_error_after_deg, 3),
                         Fx(c.response_ms, 1)});
  reports::Table frames{"catch_up_frames",
                        "Catch-up frames, one row per frame (t_s: arrival from the trial's start; error: the target's "
                        "horizontal angle in the camera; action: what the controller did)",
                        {"trial",
                         "speed_deg_per_s",
                         "direction",
                         "k",
                         "t_s",
                         "target_az_deg",
                         "cmd_us",
                         "found",
                         "x_px",
                         "error_deg",
                         "true_error_deg",
                         "action"},
                        {}};
  for (const CatchUpFrame& f : s.frames)
    frames.rows.push_back({std::to_string(f.trial),
                           Fx(f.speed_deg_per_s, 2),
                           std::to_string(f.direction),
                           std::to_string(f.k),
                           Fx(f.t_s, 6),
                           Fx(f.target_az_deg, 4),
                           std::to_string(f.cmd_us),
                           f.found ? "1" : "0",
                           Fx(f.x_px, 3),
                           Fx(f.error_deg, 4),
                           Fx(f.true_error_deg, 4),
                           f.action});
  reports::WriteTable(trials, out + "/tables");
  reports::WriteTable(sacc, out + "/tables");
  reports::WriteTextFile(out + "/tables/catch_up_frames.csv", reports::ToCsv(frames));

  // The fastest trial with frames.
  const CatchUpTrial* shown = nullptr;
  for (const CatchUpTrial& t : s.trials)
    if (t.frames > 0 && (!shown || t.speed_deg_per_s > shown->speed_deg_per_s)) shown = &t;
  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  if (shown) {
    reports::Figure tr;
    tr.name = "catch_up_trace";
    tr.title = "Pursuit of a target at " + Fx(shown->speed_deg_per_s, 0) + " deg/s: retinal error";
    tr.xlabel = "time from the trial's start (frame arrival) [s]";
    tr.ylabel = "target's horizontal angle in the camera [deg]";
    reports::Series m{"measured from the frames", "lines lw 2 lc rgb '#1f77b4'", "1:2", {"t_s", "error_deg"}, {}};
    reports::Series t{
        "truth at the exposure", "lines dt 2 lw 1.5 lc rgb '#444444'", "1:2", {"t_s", "true_error_deg"}, {}};
    reports::Series c{"catch-up saccade sent", "points pt 7 ps 1.8 lc rgb '#d62728'", "1:2", {"t_s", "error_deg"}, {}};
    for (const CatchUpFrame& f : s.frames) {
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
    tr.caption = "The target's angle from the eye's optical axis while it moves at " + Fx(shown->speed_deg_per_s, 0) +
                 " deg/s: the P-loop pursuit falls behind, and each catch-up "
                 "saccade (red dots: the frame that triggered it) brings the error back; each leads the target by "
                 "its estimated speed, so one sent as the target stops at the end of its sweep overshoots. " +
                 std::to_string(shown->saccades) + " catch-up saccades; RMS error " + Fx(shown->rms_error_deg, 2) +
                 " deg while the target moved.";
    figs.push_back(reports::WriteFigure(tr, out + "/figures", draw));
    drawn.push_back(tr);
  }
  reports::WriteTextFile(out + "/catch_up.json", CatchUpStudyJson(s).dump(2) + "\n");
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

}  // namespace owlcal::pipeline
