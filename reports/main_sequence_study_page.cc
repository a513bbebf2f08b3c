// The main-sequence study's page (WriteMainSequenceStudy, evaluation/main_sequence_study.h): the
// saccade, summary and frame tables, the peak-velocity, duration and trace figures, and the page.
#include "reports/main_sequence_study_page.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/number_text.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::reports {
namespace {
namespace fs = std::filesystem;

// Error of an estimate against the truth, in % and in its sigma.
std::string Pct(double v, double truth) {
  return std::isfinite(v) && std::isfinite(truth) && truth != 0 ? evaluation::Fx(100 * (v - truth) / truth, 2) : "";
}
std::string Z(double v, double sigma, double truth) {
  return std::isfinite(v) && std::isfinite(truth) && sigma > 0 && std::isfinite(sigma)
             ? evaluation::Fx((v - truth) / sigma, 2)
             : "";
}

// main_sequence_saccades: one row per saccade, measured and true.
reports::Table MainSequenceSaccadeTable(const evaluation::MainSequenceStudy& s) {
  const double vth = s.fit.velocity_threshold_deg_per_s;
  reports::Table sac{"main_sequence_saccades",
                     "Saccades, one row per saccade: amplitude, peak angular velocity and duration (angular "
                     "velocity above " +
                         evaluation::Fx(vth, 0) +
                         " deg/s) measured from the frames with the pooled lag and delay, +- sigma; truth from the "
                         "virtual Owl's servo law at the true amplitude",
                     {"saccade",
                      "amplitude_cmd_deg",
                      "repeat",
                      "direction",
                      "servo",
                      "from_us",
                      "to_us",
                      "map_amplitude_deg",
                      "phase_ms",
                      "frames",
                      "measured",
                      "status",
                      "reason",
                      "amplitude_deg",
                      "amplitude_sigma_deg",
                      "slew_deg_per_s",
                      "slew_sigma_deg_per_s",
                      "peak_deg_per_s",
                      "peak_sigma_deg_per_s",
                      "duration_ms",
                      "duration_sigma_ms",
                      "rms_deg",
                      "true_amplitude_deg",
                      "true_peak_deg_per_s",
                      "true_duration_ms",
                      "peak_error_pct"},
                     {}};
  for (const evaluation::MainSequenceSaccade& sa : s.saccades) {
    const bool m = sa.m.ok;
    sac.rows.push_back({std::to_string(sa.saccade),
                        evaluation::Fx(sa.amplitude_cmd_deg, 2),
                        std::to_string(sa.repeat),
                        std::to_string(sa.direction),
                        sa.servo,
                        sa.from_us ? std::to_string(sa.from_us) : "",
                        sa.to_us ? std::to_string(sa.to_us) : "",
                        evaluation::Fx(sa.map_amplitude_deg, 3),
                        evaluation::Fx(sa.phase_ms, 2),
                        std::to_string(sa.frames),
                        std::to_string(sa.measured),
                        sa.status,
                        sa.reason,
                        m ? evaluation::Fx(sa.m.amplitude_deg, 3) : "",
                        m ? evaluation::Fx(sa.m.amplitude_sigma_deg, 4) : "",
                        m ? evaluation::Fx(sa.m.slew_deg_per_s, 1) : "",
                        m ? evaluation::Fx(sa.m.slew_sigma_deg_per_s, 1) : "",
                        m ? evaluation::Fx(sa.m.peak_deg_per_s, 2) : "",
                        m ? evaluation::Fx(sa.m.peak_sigma_deg_per_s, 2) : "",
                        m ? evaluation::Fx(1000 * sa.m.duration_s, 2) : "",
                        m ? evaluation::Fx(1000 * sa.m.duration_sigma_s, 2) : "",
                        m ? evaluation::Fx(sa.m.rms_deg, 4) : "",
                        evaluation::Fx(sa.true_amplitude_deg, 3),
                        evaluation::Fx(sa.true_peak_deg_per_s, 2),
                        evaluation::Fx(1000 * sa.true_duration_s, 2),
                        m ? Pct(sa.m.peak_deg_per_s, sa.true_peak_deg_per_s) : ""});
  }
  return sac;
}

// main_sequence_summary: the slew and lag of each estimate against the truth.
reports::Table MainSequenceSummaryTable(const evaluation::MainSequenceStudy& s) {
  const fitting::MainSequenceFit& f = s.fit;
  const double vth = f.velocity_threshold_deg_per_s;
  reports::Table sum{"main_sequence_summary",
                     "Slew and lag of " + s.servo +
                         ": each estimate with sigma, against the virtual Owl's truth (error in % and in sigma)",
                     {"estimate",
                      "saccades",
                      "slew_deg_per_s",
                      "slew_sigma_deg_per_s",
                      "true_slew_deg_per_s",
                      "slew_error_pct",
                      "slew_z",
                      "lag_ms",
                      "lag_sigma_ms",
                      "true_lag_ms",
                      "lag_error_pct",
                      "lag_z",
                      "note"},
                     {}};
  const double ts = s.true_slew_deg_per_s, tl = s.true_lag_s;
  auto sum_row = [&](const std::string& name,
                     bool ok,
                     int n,
                     double sl,
                     double sls,
                     double lg,
                     double lgs,
                     const std::string& note) {
    sum.rows.push_back({name,
                        std::to_string(n),
                        ok ? evaluation::Fx(sl, 1) : "",
                        ok ? evaluation::Fx(sls, 1) : "",
                        evaluation::Fx(ts, 1),
                        ok ? Pct(sl, ts) : "",
                        ok ? Z(sl, sls, ts) : "",
                        ok ? evaluation::Fx(1000 * lg, 2) : "",
                        ok ? evaluation::Fx(1000 * lgs, 2) : "",
                        evaluation::Fx(1000 * tl, 2),
                        ok ? Pct(lg, tl) : "",
                        ok ? Z(lg, lgs, tl) : "",
                        note});
  };
  sum_row("main sequence: V = Vmax (1 - exp(-A / C)), slew = Vmax, lag = C / Vmax",
          f.peak.ok,
          f.peak.num_saccades,
          f.peak.vmax_deg_per_s,
          f.peak.vmax_sigma_deg_per_s,
          f.peak.lag_s,
          f.peak.lag_sigma_s,
          f.peak.ok ? "RMS " + evaluation::Fx(f.peak.rms_deg_per_s, 2) + " deg/s" : f.peak.message);
  sum_row("duration against amplitude (servo law, time above " + evaluation::Fx(vth, 0) + " deg/s)",
          f.duration.ok,
          f.duration.num_saccades,
          f.duration.slew_deg_per_s,
          f.duration.slew_sigma_deg_per_s,
          f.duration.lag_s,
          f.duration.lag_sigma_s,
          f.duration.ok ? "RMS " + evaluation::Fx(1000 * f.duration.rms_s, 2) + " ms" : f.duration.message);
  sum_row("pooled trajectory fit (all frames)",
          f.motion.ok,
          f.motion.num_saccades,
          f.motion.slew_deg_per_s,
          f.motion.slew_sigma_deg_per_s,
          f.motion.lag_s,
          f.motion.lag_sigma_s,
          f.motion.ok ? "delay " + evaluation::Fx(1000 * f.motion.delay_s, 2) + " +- " +
                            evaluation::Fx(1000 * f.motion.delay_sigma_s, 2) + " ms, RMS " +
                            evaluation::Fx(f.motion.rms_deg, 4) + " deg"
                      : f.motion.message);
  if (s.has_truth && s.truth_fit.motion.ok)
    sum_row("pooled fit on the TRUE angles at the frames (estimator check, not a measurement)",
            true,
            s.truth_fit.motion.num_saccades,
            s.truth_fit.motion.slew_deg_per_s,
            s.truth_fit.motion.slew_sigma_deg_per_s,
            s.truth_fit.motion.lag_s,
            s.truth_fit.motion.lag_sigma_s,
            "delay " + evaluation::Fx(1000 * s.truth_fit.motion.delay_s, 2) + " ms");
  return sum;
}

// main_sequence_frames: one row per frame.
reports::Table MainSequenceFramesTable(const evaluation::MainSequenceStudy& s) {
  reports::Table frames{"main_sequence_frames",
                        "Main-sequence frames: one row per frame (t_s: arrival from the command; angles: the pan "
                        "joint in the map's convention; empty = not measured or no truth)",
                        {"saccade", "k", "t_s", "cmd_us", "found", "x_px", "y_px", "angle_deg", "true_angle_deg"},
                        {}};
  for (const evaluation::MainSequenceFrame& fr : s.frames)
    frames.rows.push_back({std::to_string(fr.saccade),
                           std::to_string(fr.k),
                           evaluation::Fx(fr.t_s, 6),
                           std::to_string(fr.cmd_us),
                           fr.found ? "1" : "0",
                           evaluation::Fx(fr.x_px, 3),
                           evaluation::Fx(fr.y_px, 3),
                           evaluation::Fx(fr.angle_deg, 5),
                           evaluation::Fx(fr.true_angle_deg, 5)});
  return frames;
}

// A curve of fn(amplitude) over amplitudes up to a little beyond amax, its non-finite points left out.
template <typename Fn>
reports::Series MainSequenceCurve(
    double amax, const std::string& title, const std::string& style, const std::string& col, Fn fn) {
  reports::Series c{title, style, "1:2", {"amplitude_deg", col}, {}};
  for (int i = 1; i <= 200; ++i) {
    const double a = 1.1 * amax * i / 200;
    const double v = fn(a);
    if (std::isfinite(v)) c.rows.push_back({a, v});
  }
  return c;
}

// Peak velocity against amplitude.
reports::Figure MainSequencePeakFigure(const evaluation::MainSequenceStudy& s, double amax) {
  const fitting::MainSequenceFit& f = s.fit;
  const double ts = s.true_slew_deg_per_s, tl = s.true_lag_s;
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const char* grey = "#444444";
  reports::Figure pk;
  pk.name = "main_sequence_peak";
  pk.title = "Main sequence of " + s.servo + ": peak angular velocity against amplitude";
  pk.xlabel = "saccade amplitude [deg]";
  pk.ylabel = "peak angular velocity [deg/s]";
  reports::Series pts{"saccades, from the frames (+-2 sigma)",
                      std::string("yerrorbars pt 7 ps 1.2 lc rgb '") + blue + "'",
                      "1:2:($3*2)",
                      {"amplitude_deg", "peak_deg_per_s", "peak_sigma_deg_per_s"},
                      {}};
  for (const evaluation::MainSequenceSaccade& sa : s.saccades)
    if (sa.m.ok) pts.rows.push_back({sa.m.amplitude_deg, sa.m.peak_deg_per_s, sa.m.peak_sigma_deg_per_s});
  pk.series.push_back(pts);
  if (f.peak.ok)
    pk.series.push_back(MainSequenceCurve(
        amax,
        "fit: Vmax = " + evaluation::Fx(f.peak.vmax_deg_per_s, 1) + " +- " +
            evaluation::Fx(f.peak.vmax_sigma_deg_per_s, 1) + " deg/s, C = " + evaluation::Fx(f.peak.c_deg, 2) + " deg",
        std::string("lines lw 2 lc rgb '") + red + "'",
        "fit_peak_deg_per_s",
        [&](double a) { return f.peak.vmax_deg_per_s * (1 - std::exp(-a / f.peak.c_deg)); }));
  if (s.has_truth)
    pk.series.push_back(MainSequenceCurve(
        amax,
        "truth: slew " + evaluation::Fx(ts, 0) + " deg/s, lag " + evaluation::Fx(1000 * tl, 0) + " ms",
        std::string("lines dt 2 lw 2 lc rgb '") + grey + "'",
        "true_peak_deg_per_s",
        [&](double a) { return fitting::PeakVelocityDegPerS(a, ts, tl); }));
  pk.settings = {"set grid", "set xrange [0:*]", "set yrange [0:*]"};
  pk.key = "bottom right";  // below, the legend hid the x label; the curve leaves this corner empty
  pk.caption =
      "Peak angular velocity of each saccade measured from the frames (+-2 sigma bars) against its "
      "amplitude, the fitted main sequence V = Vmax (1 - exp(-A / C)) (for the servo's linear slew with a "
      "first-order lag, Vmax is the slew and C = slew x lag)" +
      std::string(s.has_truth ? " and the truth's curve (dashed)" : "") + ".";
  return pk;
}

// Duration against amplitude.
reports::Figure MainSequenceDurationFigure(const evaluation::MainSequenceStudy& s, double amax) {
  const fitting::MainSequenceFit& f = s.fit;
  const double vth = f.velocity_threshold_deg_per_s;
  const double ts = s.true_slew_deg_per_s, tl = s.true_lag_s;
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const char* grey = "#444444";
  reports::Figure du;
  du.name = "main_sequence_duration";
  du.title = "Saccade duration of " + s.servo + " against amplitude (angular velocity above " + evaluation::Fx(vth, 0) +
             " deg/s)";
  du.xlabel = "saccade amplitude [deg]";
  du.ylabel = "duration [ms]";
  reports::Series dp{"saccades, from the frames (+-2 sigma)",
                     std::string("yerrorbars pt 7 ps 1.2 lc rgb '") + blue + "'",
                     "1:2:($3*2)",
                     {"amplitude_deg", "duration_ms", "duration_sigma_ms"},
                     {}};
  for (const evaluation::MainSequenceSaccade& sa : s.saccades)
    if (sa.m.ok && std::isfinite(sa.m.duration_s))
      dp.rows.push_back({sa.m.amplitude_deg, 1000 * sa.m.duration_s, 1000 * sa.m.duration_sigma_s});
  du.series.push_back(dp);
  if (f.duration.ok)
    du.series.push_back(MainSequenceCurve(
        amax,
        "fit: slew " + evaluation::Fx(f.duration.slew_deg_per_s, 1) + " +- " +
            evaluation::Fx(f.duration.slew_sigma_deg_per_s, 1) + " deg/s, lag " +
            evaluation::Fx(1000 * f.duration.lag_s, 1) + " ms",
        std::string("lines lw 2 lc rgb '") + red + "'",
        "fit_duration_ms",
        [&](double a) { return 1000 * fitting::DurationS(a, f.duration.slew_deg_per_s, f.duration.lag_s, vth); }));
  if (s.has_truth)
    du.series.push_back(MainSequenceCurve(
        amax,
        "truth: slew " + evaluation::Fx(ts, 0) + " deg/s, lag " + evaluation::Fx(1000 * tl, 0) + " ms",
        std::string("lines dt 2 lw 2 lc rgb '") + grey + "'",
        "true_duration_ms",
        [&](double a) { return 1000 * fitting::DurationS(a, ts, tl, vth); }));
  du.settings = {"set grid", "set xrange [0:*]", "set yrange [0:*]"};
  du.key = "bottom right";
  du.caption = "Duration of each saccade (the time its angular velocity is above " + evaluation::Fx(vth, 0) +
               " deg/s) against its amplitude, with the servo law's duration fitted to them" +
               std::string(s.has_truth ? " and the truth's (dashed)" : "") +
               ": above a few degrees it grows by 1/slew per degree.";
  return du;
}

// The largest saccades' frames on one time axis: each frame at its time from the motion's onset
// (arrival - fitted delay), the angle from the saccade's start in its direction.
reports::Figure MainSequenceTracesFigure(const evaluation::MainSequenceStudy& s) {
  const fitting::MainSequenceFit& f = s.fit;
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const char* grey = "#444444";
  double big = 0;
  for (const evaluation::MainSequenceSaccade& sa : s.saccades)
    if (sa.m.ok) big = std::max(big, sa.amplitude_cmd_deg);
  reports::Figure tr;
  tr.name = "main_sequence_traces";
  tr.title = evaluation::Fx(big, 0) + " deg saccades of " + s.servo + ": every frame on one time axis";
  tr.xlabel = "time from the motion's onset (arrival - fitted delay) [ms]";
  tr.ylabel = "angle from the start [deg]";
  reports::Series pts{"frames of the " + evaluation::Fx(big, 0) + " deg saccades (measured)",
                      std::string("points pt 7 ps 1.2 lc rgb '") + blue + "'",
                      "1:2",
                      {"t_ms", "angle_deg"},
                      {}};
  reports::Series tpts{"the same frames, true angle",
                       std::string("points pt 6 ps 1.8 lc rgb '") + grey + "'",
                       "1:2",
                       {"t_ms", "true_angle_deg"},
                       {}};
  double a_mean = 0;
  int na = 0;
  for (const evaluation::MainSequenceSaccade& sa : s.saccades) {
    if (!sa.m.ok || sa.amplitude_cmd_deg != big) continue;
    a_mean += sa.m.amplitude_deg;
    ++na;
    // The true angles from their own first and last frames (the truth's zero and sign may differ
    // from the map's).
    double t_first = NAN, t_last = NAN;
    for (const evaluation::MainSequenceFrame& fr : s.frames)
      if (fr.saccade == sa.saccade && std::isfinite(fr.true_angle_deg)) {
        if (!std::isfinite(t_first)) t_first = fr.true_angle_deg;
        t_last = fr.true_angle_deg;
      }
    const double t_dir = t_last >= t_first ? 1 : -1;
    for (const evaluation::MainSequenceFrame& fr : s.frames)
      if (fr.saccade == sa.saccade) {
        const double t = 1000 * (fr.t_s - f.motion.delay_s);
        if (std::isfinite(fr.angle_deg)) pts.rows.push_back({t, sa.m.direction * (fr.angle_deg - sa.m.start_deg)});
        if (std::isfinite(fr.true_angle_deg)) tpts.rows.push_back({t, t_dir * (fr.true_angle_deg - t_first)});
      }
  }
  a_mean /= std::max(1, na);
  std::sort(pts.rows.begin(), pts.rows.end());
  std::sort(tpts.rows.begin(), tpts.rows.end());
  tr.series.push_back(pts);
  if (!tpts.rows.empty()) tr.series.push_back(tpts);
  reports::Series model{"pooled fit: slew " + evaluation::Fx(f.motion.slew_deg_per_s, 1) + " deg/s, lag " +
                            evaluation::Fx(1000 * f.motion.lag_s, 1) + " ms",
                        std::string("lines lw 2 lc rgb '") + red + "'",
                        "1:2",
                        {"t_ms", "fit_angle_deg"},
                        {}};
  const double t0 = pts.rows.empty() ? -100 : pts.rows.front()[0], t1 = pts.rows.empty() ? 400 : pts.rows.back()[0];
  for (int i = 0; i <= 400; ++i) {
    const double t = t0 + (t1 - t0) * i / 400;
    model.rows.push_back({t, fitting::SaccadeAngleDeg(t / 1000, a_mean, f.motion.slew_deg_per_s, f.motion.lag_s)});
  }
  tr.series.push_back(model);
  tr.settings = {"set grid"};
  tr.key = "bottom right";
  tr.caption = "Every frame of the " + evaluation::Fx(big, 0) +
               " deg saccades placed at its time from the motion's onset: the commands fell at different phases "
               "of the 30 fps frame clock, so together the saccades sample the trajectory densely although each "
               "lasts only a few frames. The line is the pooled slew-and-lag fit" +
               std::string(tpts.rows.empty() ? "" : "; open circles are the true angles at the same frames") + ".";
  return tr;
}

}  // namespace

std::string WriteMainSequenceStudy(const evaluation::MainSequenceStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");
  const fitting::MainSequenceFit& f = s.fit;
  const reports::Table sac = MainSequenceSaccadeTable(s);
  const reports::Table sum = MainSequenceSummaryTable(s);
  const reports::Table frames = MainSequenceFramesTable(s);
  reports::WriteTable(sac, out + "/tables");
  reports::WriteTable(sum, out + "/tables");
  reports::WriteTextFile(out + "/tables/main_sequence_frames.csv", reports::ToCsv(frames));

  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  double amax = 0;
  for (const evaluation::MainSequenceSaccade& sa : s.saccades)
    if (sa.m.ok) amax = std::max(amax, sa.m.amplitude_deg);
  if (amax > 0) {
    const reports::Figure pk = MainSequencePeakFigure(s, amax);
    figs.push_back(reports::WriteFigure(pk, out + "/figures", draw));
    drawn.push_back(pk);
    const reports::Figure du = MainSequenceDurationFigure(s, amax);
    figs.push_back(reports::WriteFigure(du, out + "/figures", draw));
    drawn.push_back(du);
  }
  if (f.motion.ok && amax > 0) {
    const reports::Figure tr = MainSequenceTracesFigure(s);
    figs.push_back(reports::WriteFigure(tr, out + "/figures", draw));
    drawn.push_back(tr);
  }

  reports::WriteTextFile(out + "/main_sequence.json", evaluation::MainSequenceStudyJson(s).dump(2) + "\n");

  reports::ExperimentPage page;
  page.title = "saccade main sequence";
  page.heading = "Saccade main sequence";
  page.intro_html = std::string(
      "Source: " + reports::HtmlEscape(s.source) + ". Servo " + reports::HtmlEscape(s.servo) + ", eye on the " +
      reports::HtmlEscape(s.map) + ". " + std::to_string(s.num_ok) + " of " + std::to_string(s.num_saccades) +
      " saccades ok. Each saccade jumps across the fixation target; the eye's angle in every frame comes from the "
      "target's pixel through the lens and head geometry (protocols/main_sequence_step.h). The servo's slew, lag "
      "and the command-to-frame delay are fitted to all frames at once, each saccade's peak velocity and duration "
      "follow from its own fit (fitting/main_sequence_fit.h).");
  page.figures = drawn;
  page.files = figs;
  page.tables_html = reports::ToHtml(sum) + "\n";
  page.notes = s.notes;
  page.after_notes_html = reports::ToHtml(sac) + "\n<p>Every frame: tables/main_sequence_frames.csv.</p>\n";
  return reports::WriteExperimentPage(page, out);
}

}  // namespace owlcal::reports
