#include "pipeline/vor_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/study_cells.h"
#include "protocols/dataset.h"
#include "reports/experiment_page.h"
#include "reports/gnuplot_figure.h"
#include "reports/table.h"

namespace owlcal::pipeline {
namespace {
namespace fs = std::filesystem;

constexpr double kStepLeadS = 0.5;  // protocols/vor_step.cc: a step profile's rest before the step

struct TrialInfo {
  std::string status, reason, map;
  int frames = 0;
};

// The frames of one trial and eye, in order.
std::vector<const VorFrame*> Select(const std::vector<VorFrame>& frames, int trial, int eye) {
  std::vector<const VorFrame*> out;
  for (const VorFrame& f : frames)
    if (f.trial == trial && f.eye == eye) out.push_back(&f);
  std::sort(out.begin(), out.end(), [](const VorFrame* a, const VorFrame* b) { return a->k < b->k; });
  return out;
}

// The gain of one trial from two columns (neck, pan) of its frames; samples with either missing
// are left out.
fitting::VorGain Gain(const std::vector<const VorFrame*>& fr,
                      const VorTrialEye& te,
                      double hold_s,
                      double VorFrame::*neck,
                      double VorFrame::*pan) {
  std::vector<double> t, n, p;
  for (const VorFrame* f : fr)
    if (std::isfinite(f->*neck) && std::isfinite(f->*pan)) {
      t.push_back(f->t_s);
      n.push_back(f->*neck);
      p.push_back(f->*pan);
    }
  if (te.profile == "sine") {
    // The sine is fitted over whole cycles from the trial's start (t of the frames is the
    // receive time; the phase lag between neck and eye does not depend on it).
    return fitting::GainFromSines(
        fitting::FitSine(t, n, te.frequency_hz), fitting::FitSine(t, p, te.frequency_hz), te.frequency_hz);
  }
  return fitting::StepGain(t, n, p, kStepLeadS, hold_s);
}

}  // namespace

VorStudy EvaluateVorDataset(const std::string& dir) {
  VorStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/vor.csv", trials_csv = dir + "/vor_trials.csv";
  if (!fs::exists(trials_csv)) throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a vor dataset?)");
  const calib::CsvTable tt = protocols::ReadAppendedCsv(trials_csv);
  tt.RequireColumns(
      {"trial", "profile", "frequency_hz", "amplitude_deg", "condition", "frames", "map", "status", "reason"});
  std::map<int, TrialInfo> trials;
  std::map<int, VorTrialEye> proto;
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    const int trial = tt.Int(r, "trial", 0, 1000000);
    TrialInfo& ti = trials[trial];
    ti.status = tt.Text(r, "status");
    ti.reason = tt.Text(r, "reason");
    ti.map = tt.Text(r, "map");
    ti.frames = tt.Int(r, "frames", 0, 100000000);
    VorTrialEye& te = proto[trial];
    te.trial = trial;
    te.profile = tt.Text(r, "profile");
    te.condition = tt.Text(r, "condition");
    te.frequency_hz = tt.Text(r, "frequency_hz").empty() ? 0 : tt.Number(r, "frequency_hz", 0, 100);
    te.amplitude_deg = tt.Number(r, "amplitude_deg", 0, 90);
    if (s.map.empty()) s.map = ti.map;
  }
  s.num_trials = int(trials.size());
  if (fs::exists(frames_csv)) {
    const calib::CsvTable t = protocols::ReadAppendedCsv(frames_csv);
    t.RequireColumns({"trial",
                      "k",
                      "t_s",
                      "eye",
                      "neck_cmd_us",
                      "pan_cmd_us",
                      "neck_cmd_deg",
                      "pan_cmd_deg",
                      "found",
                      "x_px",
                      "y_px",
                      "gaze_err_deg",
                      "neck_deg",
                      "pan_deg",
                      "true_neck_deg",
                      "true_pan_deg",
                      "true_x_px",
                      "true_y_px",
                      "true_gaze_err_deg"});
    for (size_t r = 0; r < t.NumRows(); ++r) {
      VorFrame f;
      f.trial = t.Int(r, "trial", 0, 1000000);
      f.profile = t.Text(r, "profile");
      f.condition = t.Text(r, "condition");
      f.frequency_hz = t.Text(r, "frequency_hz").empty() ? 0 : t.Number(r, "frequency_hz", 0, 100);
      f.amplitude_deg = t.Number(r, "amplitude_deg", 0, 90);
      f.k = t.Int(r, "k", 0, 100000000);
      f.t_s = t.Number(r, "t_s", -1e6, 1e6);
      const std::string eye = t.Text(r, "eye");
      if (eye != models::kEyeNames[0] && eye != models::kEyeNames[1])
        throw std::runtime_error(t.Where(r) + ": eye '" + eye + "' is neither left nor right");
      f.eye = eye == models::kEyeNames[0] ? 0 : 1;
      f.neck_cmd_us = t.Int(r, "neck_cmd_us", 0, 9999);
      f.pan_cmd_us = t.Int(r, "pan_cmd_us", 0, 9999);
      f.neck_cmd_deg = t.Number(r, "neck_cmd_deg");
      f.pan_cmd_deg = t.Number(r, "pan_cmd_deg");
      f.found = t.Int(r, "found", 0, 1) == 1;
      f.x_px = Opt(t, r, "x_px");
      f.y_px = Opt(t, r, "y_px");
      f.gaze_err_deg = Opt(t, r, "gaze_err_deg");
      f.neck_deg = Opt(t, r, "neck_deg");
      f.pan_deg = Opt(t, r, "pan_deg");
      f.true_neck_deg = Opt(t, r, "true_neck_deg");
      f.true_pan_deg = Opt(t, r, "true_pan_deg");
      f.true_x_px = Opt(t, r, "true_x_px");
      f.true_y_px = Opt(t, r, "true_y_px");
      f.true_gaze_err_deg = Opt(t, r, "true_gaze_err_deg");
      if (std::isfinite(f.true_neck_deg)) s.has_truth = true;
      s.frames.push_back(f);
    }
  } else {
    s.notes.push_back(frames_csv + " does not exist: no frame was logged");
  }
  // A step's hold: from the step trials' frame count (lead 0.5 s + 2 holds at 30 fps).
  for (const auto& [trial, ti] : trials) {
    const VorTrialEye& base = proto[trial];
    const double hold_s = base.profile == "step" ? std::max(0.2, (ti.frames / 30.0 - kStepLeadS) / 2) : 0;
    for (int e = 0; e < 2; ++e) {
      VorTrialEye te = base;
      te.eye = e;
      te.status = ti.status;
      te.reason = ti.reason;
      const std::vector<const VorFrame*> fr = Select(s.frames, trial, e);
      te.num_frames = int(fr.size());
      std::vector<double> t, x, ang, tx, tang;
      std::vector<bool> found, tfound;
      for (const VorFrame* f : fr) {
        te.num_found += f->found ? 1 : 0;
        t.push_back(f->t_s);
        x.push_back(f->x_px);
        ang.push_back(f->gaze_err_deg);
        found.push_back(f->found);
        tx.push_back(f->true_x_px);
        tang.push_back(f->true_gaze_err_deg);
        tfound.push_back(std::isfinite(f->true_x_px));
      }
      te.slip = fitting::ComputeSlip(t, x, ang, found);
      if (s.has_truth) te.true_slip = fitting::ComputeSlip(t, tx, tang, tfound);
      if (te.condition == "vor") {
        te.gain = Gain(fr, te, hold_s, &VorFrame::neck_deg, &VorFrame::pan_deg);
        te.map_gain = Gain(fr, te, hold_s, &VorFrame::neck_cmd_deg, &VorFrame::pan_cmd_deg);
        if (s.has_truth) te.true_gain = Gain(fr, te, hold_s, &VorFrame::true_neck_deg, &VorFrame::true_pan_deg);
        if (te.status == "ok" && !te.gain.ok) {
          te.status = "failed";
          te.reason = "gain not measured: " + te.gain.reason;
        }
      }
      if (te.num_frames == 0 && te.status == "ok") {
        te.status = "failed";
        te.reason = "no frame logged";
      }
      if (te.status != "ok")
        s.notes.push_back("trial " + std::to_string(trial) + " (" + te.profile + " " + Fx(te.amplitude_deg, 1) +
                          " deg" + (te.profile == "sine" ? " at " + Fx(te.frequency_hz, 2) + " Hz" : "") + ", " +
                          te.condition + ", " + models::kEyeNames[e] + " eye): " + te.status + ": " + te.reason);
      s.results.push_back(te);
    }
    if (ti.status == "ok") ++s.num_ok;
  }
  if (s.map.find("nominal") != std::string::npos)
    s.notes.insert(s.notes.begin(),
                   "the eyes counter-rotated on the robot file's NOMINAL maps (no calibration given): run owlcal "
                   "calibrate and pass --calib for the fitted head");
  if (!s.has_truth) s.notes.push_back("no truth: a real robot (the virtual Owl logs the true angles and slip)");
  return s;
}

nlohmann::json VorStudyJson(const VorStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["map"] = s.map;
  j["num_trials"] = s.num_trials;
  j["num_ok"] = s.num_ok;
  j["has_truth"] = s.has_truth;
  j["notes"] = s.notes;
  auto gain = [](const fitting::VorGain& g) {
    nlohmann::json o = {{"ok", g.ok}};
    if (!g.ok) {
      o["reason"] = g.reason;
      return o;
    }
    o["gain"] = g.gain;
    o["gain_sigma"] = g.gain_sigma;
    o["lag_deg"] = g.lag_deg;
    o["lag_sigma_deg"] = g.lag_sigma_deg;
    o["lag_ms"] = g.lag_ms;
    o["lag_sigma_ms"] = g.lag_sigma_ms;
    return o;
  };
  auto slip = [](const fitting::SlipStats& x) {
    return nlohmann::json{{"samples", x.num_samples},
                          {"rms_px", x.rms_px},
                          {"peak_px", x.peak_px},
                          {"rms_px_per_s", x.rms_px_per_s},
                          {"peak_px_per_s", x.peak_px_per_s},
                          {"rms_deg_per_s", x.rms_deg_per_s},
                          {"peak_deg_per_s", x.peak_deg_per_s}};
  };
  j["trials"] = nlohmann::json::array();
  for (const VorTrialEye& r : s.results) {
    nlohmann::json o = {{"trial", r.trial},
                        {"profile", r.profile},
                        {"frequency_hz", r.frequency_hz},
                        {"amplitude_deg", r.amplitude_deg},
                        {"condition", r.condition},
                        {"eye", models::kEyeNames[r.eye]},
                        {"status", r.status},
                        {"reason", r.reason},
                        {"frames", r.num_frames},
                        {"found", r.num_found},
                        {"slip", slip(r.slip)}};
    if (r.true_slip) o["true_slip"] = slip(*r.true_slip);
    if (r.condition == "vor") {
      o["gain"] = gain(r.gain);
      o["map_gain"] = gain(r.map_gain);
      if (r.true_gain) o["true_gain"] = gain(*r.true_gain);
    }
    j["trials"].push_back(o);
  }
  return j;
}

std::string WriteVorStudy(const VorStudy& s, const std::string& out, bool draw) {
  fs::create_directories(out + "/tables");
  fs::create_directories(out + "/figures");
  fs::create_directories(out + "/report");

  auto gcell = [](const fitting::VorGain& g, double fitting::VorGain::*v, int d) {
    return g.ok ? Fx(g.*v, d) : std::string();
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
  for (const VorTrialEye& r : s.results) {
    const bool v = r.condition == "vor";
    const bool tg = v && r.true_gain && r.true_gain->ok && r.gain.ok;
    results.rows.push_back(
        {std::to_string(r.trial),
         r.profile,
         r.profile == "sine" ? Fx(r.frequency_hz, 3) : "",
         Fx(r.amplitude_deg, 2),
         r.condition,
         models::kEyeNames[r.eye],
         r.status,
         r.reason,
         std::to_string(r.num_frames),
         std::to_string(r.num_found),
         Fx(r.slip.rms_px, 3),
         Fx(r.slip.peak_px, 3),
         Fx(r.slip.rms_px_per_s, 2),
         Fx(r.slip.peak_px_per_s, 2),
         Fx(r.slip.rms_deg_per_s, 3),
         Fx(r.slip.peak_deg_per_s, 3),
         r.true_slip ? Fx(r.true_slip->rms_px, 3) : "",
         r.true_slip ? Fx(r.true_slip->rms_deg_per_s, 3) : "",
         r.true_slip ? Fx(r.true_slip->peak_deg_per_s, 3) : "",
         v ? gcell(r.gain, &fitting::VorGain::gain, 4) : "",
         v ? gcell(r.gain, &fitting::VorGain::gain_sigma, 4) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_deg, 2) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_sigma_deg, 2) : "",
         v && r.profile == "sine" ? gcell(r.gain, &fitting::VorGain::lag_ms, 1) : "",
         v ? gcell(r.map_gain, &fitting::VorGain::gain, 4) : "",
         v && r.profile == "sine" ? gcell(r.map_gain, &fitting::VorGain::lag_deg, 2) : "",
         v && r.true_gain ? gcell(*r.true_gain, &fitting::VorGain::gain, 4) : "",
         v && r.true_gain && r.profile == "sine" ? gcell(*r.true_gain, &fitting::VorGain::lag_deg, 2) : "",
         tg ? Fx(r.gain.gain - r.true_gain->gain, 4) : "",
         tg && r.gain.gain_sigma > 0 ? Fx((r.gain.gain - r.true_gain->gain) / r.gain.gain_sigma, 2) : ""});
  }

  // Per profile and eye: the still and the VOR trial side by side.
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
  for (const VorTrialEye& v : s.results) {
    if (v.condition != "vor") continue;
    const VorTrialEye* still = nullptr;
    for (const VorTrialEye& c : s.results)
      if (c.condition == "still" && c.eye == v.eye && c.profile == v.profile && c.frequency_hz == v.frequency_hz &&
          c.amplitude_deg == v.amplitude_deg && c.trial == v.trial - 1)
        still = &c;
    const bool sine = v.profile == "sine";
    const double red =
        still && still->slip.rms_deg_per_s > 0 ? 100 * (1 - v.slip.rms_deg_per_s / still->slip.rms_deg_per_s) : NAN;
    const bool tg = v.true_gain && v.true_gain->ok;
    summary.rows.push_back({v.profile,
                            sine ? Fx(v.frequency_hz, 3) : "",
                            Fx(v.amplitude_deg, 2),
                            models::kEyeNames[v.eye],
                            still ? Fx(still->slip.rms_deg_per_s, 3) : "",
                            Fx(v.slip.rms_deg_per_s, 3),
                            Fx(red, 1),
                            Fx(v.slip.peak_deg_per_s, 3),
                            v.true_slip ? Fx(v.true_slip->rms_deg_per_s, 3) : "",
                            v.gain.ok ? Fx(v.gain.gain, 4) : "",
                            v.gain.ok ? Fx(v.gain.gain_sigma, 4) : "",
                            tg ? Fx(v.true_gain->gain, 4) : "",
                            sine && v.gain.ok ? Fx(v.gain.lag_deg, 2) : "",
                            sine && v.gain.ok ? Fx(v.gain.lag_sigma_deg, 2) : "",
                            sine && tg ? Fx(v.true_gain->lag_deg, 2) : "",
                            v.status + (still && still->status != "ok" ? " (still: " + still->status + ")" : "")});
  }

  reports::Table frames{
      "vor_frames",
      "VOR frames: one row per frame and eye (angles in the head model's convention, gaze = neck + "
      "pan; empty = not measured or no truth)",
      {"trial",         "profile",      "frequency_hz", "amplitude_deg", "condition",        "k",
       "t_s",           "eye",          "neck_cmd_us",  "pan_cmd_us",    "neck_cmd_deg",     "pan_cmd_deg",
       "found",         "x_px",         "y_px",         "gaze_err_deg",  "neck_deg",         "pan_deg",
       "true_neck_deg", "true_pan_deg", "true_x_px",    "true_y_px",     "true_gaze_err_deg"},
      {}};
  for (const VorFrame& f : s.frames)
    frames.rows.push_back({std::to_string(f.trial),
                           f.profile,
                           f.profile == "sine" ? Fx(f.frequency_hz, 3) : "",
                           Fx(f.amplitude_deg, 2),
                           f.condition,
                           std::to_string(f.k),
                           Fx(f.t_s, 6),
                           models::kEyeNames[f.eye],
                           std::to_string(f.neck_cmd_us),
                           std::to_string(f.pan_cmd_us),
                           Fx(f.neck_cmd_deg, 4),
                           Fx(f.pan_cmd_deg, 4),
                           f.found ? "1" : "0",
                           Fx(f.x_px, 3),
                           Fx(f.y_px, 3),
                           Fx(f.gaze_err_deg, 4),
                           Fx(f.neck_deg, 4),
                           Fx(f.pan_deg, 4),
                           Fx(f.true_neck_deg, 4),
                           Fx(f.true_pan_deg, 4),
                           Fx(f.true_x_px, 3),
                           Fx(f.true_y_px, 3),
                           Fx(f.true_gaze_err_deg, 4)});
  reports::WriteTable(results, out + "/tables");
  reports::WriteTable(summary, out + "/tables");
  reports::WriteTextFile(out + "/tables/vor_frames.csv", reports::ToCsv(frames));

  // The sine shown in the time figures: the one nearest 0.5 Hz with a VOR trial.
  const VorTrialEye* shown = nullptr;
  for (const VorTrialEye& r : s.results)
    if (r.condition == "vor" && r.profile == "sine" && r.eye == models::kRightEye &&
        (!shown || std::abs(r.frequency_hz - 0.5) < std::abs(shown->frequency_hz - 0.5)))
      shown = &r;
  std::vector<reports::FigureFiles> figs;
  std::vector<reports::Figure> drawn;
  const char* blue = "#1f77b4";
  const char* red = "#d62728";
  const char* grey = "#555555";
  if (shown) {
    const std::vector<const VorFrame*> vf = Select(s.frames, shown->trial, shown->eye);
    const std::vector<const VorFrame*> sf = Select(s.frames, shown->trial - 1, shown->eye);
    auto series = [](const std::vector<const VorFrame*>& fr,
                     double VorFrame::*col,
                     double sign,
                     const std::string& title,
                     const std::string& style,
                     const std::string& name) {
      reports::Series se{title, style, "1:2", {"t_s", name}, {}};
      double first = NAN;
      for (const VorFrame* f : fr)
        if (std::isfinite(f->*col)) {
          if (!std::isfinite(first)) first = f->*col;
          se.rows.push_back({f->t_s, sign * (f->*col - first)});
        }
      return se;
    };
    reports::Figure tr;
    tr.name = "vor_traces";
    tr.title = "VOR at " + Fx(shown->frequency_hz, 2) + " Hz, right eye: neck and counter-rotating eye";
    tr.xlabel = "time from the trial's start [s]";
    tr.ylabel = "angle from the start [deg]";
    tr.series.push_back(series(
        vf, &VorFrame::neck_deg, 1, "neck (measured)", std::string("lines lw 2 lc rgb '") + blue + "'", "neck_deg"));
    tr.series.push_back(series(vf,
                               &VorFrame::pan_deg,
                               -1,
                               "-eye pan (measured)",
                               std::string("lines lw 2 lc rgb '") + red + "'",
                               "minus_pan_deg"));
    if (s.has_truth) {
      tr.series.push_back(series(vf,
                                 &VorFrame::true_neck_deg,
                                 1,
                                 "neck (truth)",
                                 std::string("lines dt 2 lw 1.5 lc rgb '") + blue + "'",
                                 "true_neck_deg"));
      tr.series.push_back(series(vf,
                                 &VorFrame::true_pan_deg,
                                 -1,
                                 "-eye pan (truth)",
                                 std::string("lines dt 2 lw 1.5 lc rgb '") + red + "'",
                                 "minus_true_pan_deg"));
    }
    tr.settings = {"set grid"};
    tr.key = "below";
    tr.caption = "Neck angle and the negated eye-pan angle measured from the frames (solid) during the " +
                 Fx(shown->frequency_hz, 2) + " Hz counter-rotating trial, and the truth (dashed): a perfect VOR " +
                 "makes the two curves coincide. Gain " +
                 (shown->gain.ok ? Fx(shown->gain.gain, 3) + " +- " + Fx(shown->gain.gain_sigma, 3) : "not measured") +
                 (shown->true_gain && shown->true_gain->ok ? " (truth " + Fx(shown->true_gain->gain, 3) + ")" : "") +
                 ".";
    figs.push_back(reports::WriteFigure(tr, out + "/figures", draw));
    drawn.push_back(tr);

    reports::Figure sl;
    sl.name = "vor_slip";
    sl.title = "Image slip at " + Fx(shown->frequency_hz, 2) + " Hz, right eye: eyes still against VOR";
    sl.xlabel = "time from the trial's start [s]";
    sl.ylabel = "target's x from its first position [px]";
    sl.series.push_back(
        series(sf, &VorFrame::x_px, 1, "eyes held still", std::string("lines lw 2 lc rgb '") + grey + "'", "x_px"));
    sl.series.push_back(series(
        vf, &VorFrame::x_px, 1, "eyes counter-rotating (VOR)", std::string("lines lw 2 lc rgb '") + red + "'", "x_px"));
    if (s.has_truth)
      sl.series.push_back(series(vf,
                                 &VorFrame::true_x_px,
                                 1,
                                 "VOR, true pixel",
                                 std::string("lines dt 2 lw 1.5 lc rgb '") + blue + "'",
                                 "true_x_px"));
    sl.settings = {"set grid"};
    sl.key = "below";
    sl.caption = "The target's horizontal image position during the " + Fx(shown->frequency_hz, 2) +
                 " Hz neck sine, eyes held still and counter-rotating (RMS slip " + Fx(shown->slip.rms_deg_per_s, 2) +
                 " deg/s with the VOR).";
    figs.push_back(reports::WriteFigure(sl, out + "/figures", draw));
    drawn.push_back(sl);
  }
  // Gain and phase lag against frequency.
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
    for (const VorTrialEye& r : s.results) {
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
  if (!gf.series.empty()) {
    figs.push_back(reports::WriteFigure(gf, out + "/figures", draw));
    drawn.push_back(gf);
  }

  reports::WriteTextFile(out + "/vor.json", VorStudyJson(s).dump(2) + "\n");

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

}  // namespace owlcal::pipeline
