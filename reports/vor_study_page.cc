// The VOR study's page (WriteVorStudy, evaluation/vor_study.h): the results, summary and frame
// tables, the traces, slip and gain figures, and the page.
#include "reports/vor_study_page.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {
namespace fs = std::filesystem;

// One column of the frames `fr` against time, from its first finite value, times `sign`.
reports::Series VorSeries(const std::vector<const evaluation::VorFrame*>& fr,
                          double evaluation::VorFrame::*col,
                          double sign,
                          const std::string& title,
                          const std::string& style,
                          const std::string& name) {
  reports::Series se{title, style, "1:2", {"t_s", name}, {}};
  double first = NAN;
  for (const evaluation::VorFrame* f : fr)
    if (std::isfinite(f->*col)) {
      if (!std::isfinite(first)) first = f->*col;
      se.rows.push_back({f->t_s, sign * (f->*col - first)});
    }
  return se;
}

// vor_results: per trial and eye.
reports::Table VorResultsTable(const evaluation::VorStudy& s) {
  auto gcell = [](const fitting::VorGain& g, double fitting::VorGain::*v, int d) {
    return g.ok ? evaluation::Fx(g.*v, d) : std::string();
  };
  reports::Table results{
      "vor_results",
      "VOR per trial and eye: image slip (target position from its first frame; velocity between frames) and, "
      "for the counter-rotating trials, the gain and phase lag from the frames, from the commands (map) and the "
      "truth",
      {"trial",
       "profile",
       "frequency_hz",
       "amplitude_deg",
       "condition",
       "eye",
       "status",
       "reason",
       "frames",
       "found",
       "slip_rms_px",
       "slip_peak_px",
       "slip_rms_px_per_s",
       "slip_peak_px_per_s",
       "slip_rms_deg_per_s",
       "slip_peak_deg_per_s",
       "true_slip_rms_px",
       "true_slip_rms_deg_per_s",
       "true_slip_peak_deg_per_s",
       "gain",
       "gain_sigma",
       "lag_deg",
       "lag_sigma_deg",
       "lag_ms",
       "map_gain",
       "map_lag_deg",
       "true_gain",
       "true_lag_deg",
       "gain_error",
       "gain_z"},
      {}};
  for (const evaluation::VorTrialEye& r : s.results) {
    const bool v = r.condition == "vor";
    const bool tg = v && r.true_gain && r.true_gain->ok && r.gain.ok;
    results.rows.push_back(
        {std::to_string(r.trial),
         r.profile,
         r.profile == "sine" ? evaluation::Fx(r.frequency_hz, 3) : "",
         evaluation::Fx(r.amplitude_deg, 2),
         r.condition,
         models::kEyeNames[r.eye],
         r.status,
         r.reason,
         std::to_string(r.num_frames),
         std::to_string(r.num_found),
         evaluation::Fx(r.slip.rms_px, 3),
         evaluation::Fx(r.slip.peak_px, 3),
         evaluation::Fx(r.slip.rms_px_per_s, 2),
         evaluation::Fx(r.slip.peak_px_per_s, 2),
         evaluation::Fx(r.slip.rms_deg_per_s, 3),
         evaluation::Fx(r.slip.peak_deg_per_s, 3),
         r.true_slip ? evaluation::Fx(r.true_slip->rms_px, 3) : "",
         r.true_slip ? evaluation::Fx(r.true_slip->rms_deg_per_s, 3) : "",
         r.true_slip ? evaluation::Fx(r.true_slip->peak_deg_per_s, 3) : "",
         v ? gcell(r.gain, &fitting::VorGain::gain, 4) : "",
         v ? gcell(r.gain, &fitting::VorGain::gain_sigma, 4) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_deg, 2) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_sigma_deg, 2) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_ms, 1) : "",
         v ? gcell(r.map_gain, &fitting::VorGain::gain, 4) : "",
         v && r.profile == "sine" ? gcell(r.map_gain, &fitting::VorGain::lag_deg, 2) : "",
         v && r.true_gain ? gcell(*r.true_gain, &fitting::VorGain::gain, 4) : "",
         v && r.true_gain && r.profile == "sine" ? gcell(*r.true_gain, &fitting::VorGain::lag_deg, 2) : "",
         tg ? evaluation::Fx(r.gain.gain - r.true_gain->gain, 4) : "",
         tg && r.gain.gain_sigma > 0 ? evaluation::Fx((r.gain.gain - r.true_gain->gain) / r.gain.gain_sigma, 2) : ""});
  }
  return results;
}

// Per profile and eye: the still and the VOR trial side by side.
reports::Table VorSummaryTable(const evaluation::VorStudy& s) {
  reports::Table summary{"vor_summary",
                         "VOR per profile and eye: RMS image slip with the eyes held still and counter-rotating, "
                         "the gain and phase lag from the frames (+- sigma) and the truth",
                         {"profile",
                          "frequency_hz",
                          "amplitude_deg",
                          "eye",
                          "still_slip_rms_deg_per_s",
                          "vor_slip_rms_deg_per_s",
                          "slip_reduction_pct",
                          "vor_slip_peak_deg_per_s",
                          "true_vor_slip_rms_deg_per_s",
                          "gain",
                          "gain_sigma",
                          "true_gain",
                          "lag_deg",
                          "lag_sigma_deg",
                          "true_lag_deg",
                          "status"},
                         {}};
  for (const evaluation::VorTrialEye& v : s.results) {
    if (v.condition != "vor") continue;
    const evaluation::VorTrialEye* still = nullptr;
    for (const evaluation::VorTrialEye& c : s.results)
      if (c.condition == "still" && c.eye == v.eye && c.profile == v.profile && c.frequency_hz == v.frequency_hz &&
          c.amplitude_deg == v.amplitude_deg && c.trial == v.trial - 1)
        still = &c;
    const bool sine = v.profile == "sine";
    const double red =
        still && still->slip.rms_deg_per_s > 0 ? 100 * (1 - v.slip.rms_deg_per_s / still->slip.rms_deg_per_s) : NAN;
    const bool tg = v.true_gain && v.true_gain->ok;
    summary.rows.push_back({v.profile,
                            sine ? evaluation::Fx(v.frequency_hz, 3) : "",
                            evaluation::Fx(v.amplitude_deg, 2),
                            models::kEyeNames[v.eye],
                            still ? evaluation::Fx(still->slip.rms_deg_per_s, 3) : "",
                            evaluation::Fx(v.slip.rms_deg_per_s, 3),
                            evaluation::Fx(red, 1),
                            evaluation::Fx(v.slip.peak_deg_per_s, 3),
                            v.true_slip ? evaluation::Fx(v.true_slip->rms_deg_per_s, 3) : "",
                            v.gain.ok ? evaluation::Fx(v.gain.gain, 4) : "",
                            v.gain.ok ? evaluation::Fx(v.gain.gain_sigma, 4) : "",
                            tg ? evaluation::Fx(v.true_gain->gain, 4) : "",
                            sine && v.gain.ok ? evaluation::Fx(v.gain.lag_deg, 2) : "",
                            sine && v.gain.ok ? evaluation::Fx(v.gain.lag_sigma_deg, 2) : "",
                            sine && tg ? evaluation::Fx(v.true_gain->lag_deg, 2) : "",
                            v.status + (still && still->status != "ok" ? " (still: " + still->status + ")" : "")});
  }
  return summary;
}

// vor_frames: one row per frame and eye.
reports::Table VorFramesTable(const evaluation::VorStudy& s) {
  reports::Table frames{
      "vor_frames",
      "VOR frames: one row per frame and eye (angles in the head model's convention, gaze = neck + "
      "pan; empty = not measured or no truth)",
      {"trial",         "profile",      "frequency_hz", "amplitude_deg", "condition",        "k",
       "t_s",           "eye",          "neck_cmd_us",  "pan_cmd_us",    "neck_cmd_deg",     "pan_cmd_deg",
       "found",         "x_px",         "y_px",         "gaze_err_deg",  "neck_deg",         "pan_deg",
       "true_neck_deg", "true_pan_deg", "true_x_px",    "true_y_px",     "true_gaze_err_deg"},
      {}};
  for (const evaluation::VorFrame& f : s.frames)
    frames.rows.push_back({std::to_string(f.trial),
                           f.profile,
                           f.profile == "sine" ? evaluation::Fx(f.frequency_hz, 3) : "",
                           evaluation::Fx(f.amplitude_deg, 2),
                           f.condition,
                           std::to_string(f.k),
                           evaluation::Fx(f.t_s, 6),
                           models::kEyeNames[f.eye],
                           std::to_string(f.neck_cmd_us),
                           std::to_string(f.pan_cmd_us),
                           evaluation::Fx(f.neck_cmd_deg, 4),
                           evaluation::Fx(f.pan_cmd_deg, 4),
                           f.found ? "1" : "0",
                           evaluation::Fx(f.x_px, 3),
                           evaluation::Fx(f.y_px, 3),
                           evaluation::Fx(f.gaze_err_deg, 4),
                           evaluation::Fx(f.neck_deg, 4),
                           evaluation::Fx(f.pan_deg, 4),
                           evaluation::Fx(f.true_neck_deg, 4),
                           evaluation::Fx(f.true_pan_deg, 4),
                           evaluation::Fx(f.true_x_px, 3),
                           evaluation::Fx(f.true_y_px, 3),
                           evaluation::Fx(f.true_gaze_err_deg, 4)});
  return frames;
}

// The sine shown in the time figures: the one nearest 0.5 Hz with a VOR trial.
const evaluation::VorTrialEye* VorShownSine(const evaluation::VorStudy& s) {
  const evaluation::VorTrialEye* shown = nullptr;
  for (const evaluation::VorTrialEye& r : s.results)
    if (r.condition == "vor" && r.profile == "sine" && r.eye == models::kRightEye &&
        (!shown || std::abs(r.frequency_hz - 0.5) < std::abs(shown->frequency_hz - 0.5)))
      shown = &r;
  return shown;
}

// vor_traces: the shown sine's neck and counter-rotating eye.
reports::Figure VorTracesFigure(const evaluation::VorStudy& s, const evaluation::VorTrialEye* shown) {
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const std::vector<const evaluation::VorFrame*> vf =
      evaluation::internal::SelectVorFrames(s.frames, shown->trial, shown->eye);
  reports::Figure tr;
  tr.name = "vor_traces";
  tr.title = "VOR at " + evaluation::Fx(shown->frequency_hz, 2) + " Hz, right eye: neck and counter-rotating eye";
  tr.xlabel = "time from the trial's start [s]";
  tr.ylabel = "angle from the start [deg]";
  tr.series.push_back(VorSeries(vf,
                                &evaluation::VorFrame::neck_deg,
                                1,
                                "neck (measured)",
                                std::string("lines lw 2 lc rgb '") + blue + "'",
                                "neck_deg"));
  tr.series.push_back(VorSeries(vf,
                                &evaluation::VorFrame::pan_deg,
                                -1,
                                "-eye pan (measured)",
                                std::string("lines lw 2 lc rgb '") + red + "'",
                                "minus_pan_deg"));
  if (s.has_truth) {
    tr.series.push_back(VorSeries(vf,
                                  &evaluation::VorFrame::true_neck_deg,
                                  1,
                                  "neck (truth)",
                                  std::string("lines dt 2 lw 1.5 lc rgb '") + blue + "'",
                                  "true_neck_deg"));
    tr.series.push_back(VorSeries(vf,
                                  &evaluation::VorFrame::true_pan_deg,
                                  -1,
                                  "-eye pan (truth)",
                                  std::string("lines dt 2 lw 1.5 lc rgb '") + red + "'",
                                  "minus_true_pan_deg"));
  }
  tr.settings = {"set grid"};
  tr.key = "below";
  tr.caption =
      "Neck angle and the negated eye-pan angle measured from the frames (solid) during the " +
      evaluation::Fx(shown->frequency_hz, 2) + " Hz counter-rotating trial, and the truth (dashed): a perfect VOR " +
      "makes the two curves coincide. Gain " +
      (shown->gain.ok ? evaluation::Fx(shown->gain.gain, 3) + " +- " + evaluation::Fx(shown->gain.gain_sigma, 3)
                      : "not measured") +
      (shown->true_gain && shown->true_gain->ok ? " (truth " + evaluation::Fx(shown->true_gain->gain, 3) + ")" : "") +
      ".";
  return tr;
}

// vor_slip: the shown sine's image slip, eyes still against VOR.
reports::Figure VorSlipFigure(const evaluation::VorStudy& s, const evaluation::VorTrialEye* shown) {
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const char* grey = "#555555";
  const std::vector<const evaluation::VorFrame*> vf =
      evaluation::internal::SelectVorFrames(s.frames, shown->trial, shown->eye);
  const std::vector<const evaluation::VorFrame*> sf =
      evaluation::internal::SelectVorFrames(s.frames, shown->trial - 1, shown->eye);
  reports::Figure sl;
  sl.name = "vor_slip";
  sl.title = "Image slip at " + evaluation::Fx(shown->frequency_hz, 2) + " Hz, right eye: eyes still against VOR";
  sl.xlabel = "time from the trial's start [s]";
  sl.ylabel = "target's x from its first position [px]";
  sl.series.push_back(VorSeries(
      sf, &evaluation::VorFrame::x_px, 1, "eyes held still", std::string("lines lw 2 lc rgb '") + grey + "'", "x_px"));
  sl.series.push_back(VorSeries(vf,
                                &evaluation::VorFrame::x_px,
                                1,
                                "eyes counter-rotating (VOR)",
                                std::string("lines lw 2 lc rgb '") + red + "'",
                                "x_px"));
  if (s.has_truth)
    sl.series.push_back(VorSeries(vf,
                                  &evaluation::VorFrame::true_x_px,
                                  1,
                                  "VOR, true pixel",
                                  std::string("lines dt 2 lw 1.5 lc rgb '") + blue + "'",
                                  "true_x_px"));
  sl.settings = {"set grid"};
  sl.key = "below";
  sl.caption = "The target's horizontal image position during the " + evaluation::Fx(shown->frequency_hz, 2) +
               " Hz neck sine, eyes held still and counter-rotating (RMS slip " +
               evaluation::Fx(shown->slip.rms_deg_per_s, 2) + " deg/s with the VOR).";
  return sl;
}

// Gain and phase lag against frequency.
reports::Figure VorGainFigure(const evaluation::VorStudy& s) {
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  reports::Figure gf;
  gf.name = "vor_gain";
  gf.title = "VOR gain against frequency";
  gf.xlabel = "neck frequency [Hz]";
  gf.ylabel = "VOR gain (eye / neck)";
  for (int e = 0; e < 2; ++e) {
    reports::Series m{std::string(models::kEyeNames[e]) + " eye, from the frames (+-2 sigma)",
                      std::string("yerrorbars pt 7 ps 1.3 lc rgb '") + (e ? red : blue) + "'",
                      "1:2:($3*2)",
                      {"frequency_hz", "gain", "gain_sigma"},
                      {}};
    reports::Series t{std::string(models::kEyeNames[e]) + " eye, truth",
                      std::string("points pt 6 ps 2 lc rgb '") + (e ? red : blue) + "'",
                      "1:2",
                      {"frequency_hz", "true_gain"},
                      {}};
    reports::Series c{std::string(models::kEyeNames[e]) + " eye, commanded (map)",
                      std::string("points pt 2 ps 1.3 lc rgb '") + (e ? red : blue) + "'",
                      "1:2",
                      {"frequency_hz", "map_gain"},
                      {}};
    for (const evaluation::VorTrialEye& r : s.results) {
      if (r.condition != "vor" || r.profile != "sine" || r.eye != e) continue;
      if (r.gain.ok) m.rows.push_back({r.frequency_hz, r.gain.gain, r.gain.gain_sigma});
      if (r.true_gain && r.true_gain->ok) t.rows.push_back({r.frequency_hz, r.true_gain->gain});
      if (r.map_gain.ok) c.rows.push_back({r.frequency_hz, r.map_gain.gain});
    }
    for (reports::Series* se : {&m, &t, &c})
      if (!se->rows.empty()) gf.series.push_back(*se);
  }
  gf.settings = {"set grid", "set xrange [0:*]", "set offsets 0.1, 0.1, 0.02, 0.02"};
  gf.key = "below";  // inside, the legend hid the 0.5 Hz map points
  gf.caption =
      "VOR gain (amplitude of the eye's counter-rotation over the neck's) per frequency: measured from the "
      "frames with +-2 sigma bars, the truth (open circles) and what the commands asked for through the maps "
      "(crosses).";
  return gf;
}

}  // namespace

std::string WriteVorStudy(const evaluation::VorStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");
  const reports::Table results = VorResultsTable(s);
  const reports::Table summary = VorSummaryTable(s);
  const reports::Table frames = VorFramesTable(s);
  reports::WriteTable(results, out + "/tables");
  reports::WriteTable(summary, out + "/tables");
  reports::WriteTextFile(out + "/tables/vor_frames.csv", reports::ToCsv(frames));
  const evaluation::VorTrialEye* shown = VorShownSine(s);
  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  if (shown) {
    const reports::Figure tr = VorTracesFigure(s, shown);
    figs.push_back(reports::WriteFigure(tr, out + "/figures", draw));
    drawn.push_back(tr);
    const reports::Figure sl = VorSlipFigure(s, shown);
    figs.push_back(reports::WriteFigure(sl, out + "/figures", draw));
    drawn.push_back(sl);
  }
  const reports::Figure gf = VorGainFigure(s);
  if (!gf.series.empty()) {
    figs.push_back(reports::WriteFigure(gf, out + "/figures", draw));
    drawn.push_back(gf);
  }

  reports::WriteTextFile(out + "/vor.json", evaluation::VorStudyJson(s).dump(2) + "\n");

  reports::ExperimentPage page;
  page.title = "vestibulo-ocular reflex";
  page.heading = "Vestibulo-ocular reflex";
  page.intro_html = std::string(
      "Source: " + reports::HtmlEscape(s.source) + ". Eyes on the " + reports::HtmlEscape(s.map) + ". " +
      std::to_string(s.num_ok) + " of " + std::to_string(s.num_trials) +
      " trials ok. The neck turns through each profile twice: eyes held still, then counter-rotating on the maps. "
      "Angles from the frames: the still trial's image gives the neck's motion, the VOR trial's image the eye's "
      "(protocols/vor_step.h); gain = eye amplitude / neck amplitude of fitted sines, phase lag = how far the eye's "
      "counter-rotation trails the neck.");
  page.figures = drawn;
  page.files = figs;
  page.tables_html = reports::ToHtml(summary) + "\n";
  page.notes = s.notes;
  page.after_notes_html = reports::ToHtml(results) + "\n<p>Every frame: tables/vor_frames.csv.</p>\n";
  return reports::WriteExperimentPage(page, out);
}

}  // namespace owlcal::reports
