#include "pipeline/vor_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

constexpr double kStepLeadS = 0.5;  // protocols/vor_step.cc: a step profile's rest before the step

struct TrialInfo {
  std::string status, reason, map;
  int frames = 0;
};

// The gain of one trial from two columns (neck, pan) of its frames; samples with either missing
// are left out.
fitting::VorGain Gain(const std::vector<const evaluation::VorFrame*>& fr,
                      const evaluation::VorTrialEye& te,
                      double hold_s,
                      double evaluation::VorFrame::*neck,
                      double evaluation::VorFrame::*pan) {
  std::vector<double> t, n, p;
  for (const evaluation::VorFrame* f : fr)
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

evaluation::VorStudy EvaluateVorDataset(const std::string& dir) {
  evaluation::VorStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/vor.csv", trials_csv = dir + "/vor_trials.csv";
  if (!fs::exists(trials_csv)) throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a vor dataset?)");
  const calib::CsvTable tt = protocols::ReadAppendedCsv(trials_csv);
  tt.RequireColumns(
      {"trial", "profile", "frequency_hz", "amplitude_deg", "condition", "frames", "map", "status", "reason"});
  std::map<int, TrialInfo> trials;
  std::map<int, evaluation::VorTrialEye> proto;
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    const int trial = tt.Int(r, "trial", 0, 1000000);
    TrialInfo& ti = trials[trial];
    ti.status = tt.Text(r, "status");
    ti.reason = tt.Text(r, "reason");
    ti.map = tt.Text(r, "map");
    ti.frames = tt.Int(r, "frames", 0, 100000000);
    evaluation::VorTrialEye& te = proto[trial];
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
      evaluation::VorFrame f;
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
      f.x_px = evaluation::Opt(t, r, "x_px");
      f.y_px = evaluation::Opt(t, r, "y_px");
      f.gaze_err_deg = evaluation::Opt(t, r, "gaze_err_deg");
      f.neck_deg = evaluation::Opt(t, r, "neck_deg");
      f.pan_deg = evaluation::Opt(t, r, "pan_deg");
      f.true_neck_deg = evaluation::Opt(t, r, "true_neck_deg");
      f.true_pan_deg = evaluation::Opt(t, r, "true_pan_deg");
      f.true_x_px = evaluation::Opt(t, r, "true_x_px");
      f.true_y_px = evaluation::Opt(t, r, "true_y_px");
      f.true_gaze_err_deg = evaluation::Opt(t, r, "true_gaze_err_deg");
      if (std::isfinite(f.true_neck_deg)) s.has_truth = true;
      s.frames.push_back(f);
    }
  } else {
    s.notes.push_back(frames_csv + " does not exist: no frame was logged");
  }
  // A step's hold: from the step trials' frame count (lead 0.5 s + 2 holds at 30 fps).
  for (const auto& [trial, ti] : trials) {
    const evaluation::VorTrialEye& base = proto[trial];
    const double hold_s = base.profile == "step" ? std::max(0.2, (ti.frames / 30.0 - kStepLeadS) / 2) : 0;
    for (int e = 0; e < 2; ++e) {
      evaluation::VorTrialEye te = base;
      te.eye = e;
      te.status = ti.status;
      te.reason = ti.reason;
      const std::vector<const evaluation::VorFrame*> fr = evaluation::internal::SelectVorFrames(s.frames, trial, e);
      te.num_frames = int(fr.size());
      std::vector<double> t, x, ang, tx, tang;
      std::vector<bool> found, tfound;
      for (const evaluation::VorFrame* f : fr) {
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
        te.gain = Gain(fr, te, hold_s, &evaluation::VorFrame::neck_deg, &evaluation::VorFrame::pan_deg);
        te.map_gain = Gain(fr, te, hold_s, &evaluation::VorFrame::neck_cmd_deg, &evaluation::VorFrame::pan_cmd_deg);
        if (s.has_truth)
          te.true_gain =
              Gain(fr, te, hold_s, &evaluation::VorFrame::true_neck_deg, &evaluation::VorFrame::true_pan_deg);
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
        s.notes.push_back("trial " + std::to_string(trial) + " (" + te.profile + " " +
                          evaluation::Fx(te.amplitude_deg, 1) + " deg" +
                          (te.profile == "sine" ? " at " + evaluation::Fx(te.frequency_hz, 2) + " Hz" : "") + ", " +
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

}  // namespace owlcal::pipeline
