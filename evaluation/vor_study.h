#pragma once
// The vestibulo-ocular reflex experiment: a recorded `vor` protocol (protocols/standard/vor.yaml,
// protocols/vor_step.h) evaluated per trial and eye (fitting/vor_analysis.h):
//   - image slip (the target's position and velocity in the image: px, px/s, deg/s; RMS and
//     peak) of every trial, eyes held still and counter-rotating, and on the virtual Owl the
//     true slip (the target's true pixel and angle in the camera at each frame's exposure);
//   - for the counter-rotating sines: the VOR gain and phase lag from sines fitted to the eye-pan
//     and neck angles measured from the frames, with sigma; the same from the commands through
//     the maps (what the controller asked for) and, on the virtual Owl, from the true joint
//     angles, with the error and z = error / sigma;
//   - for the steps: the steady-state gain.
// Every trial is a row with its status and reason (the recording's, or why it could not be
// evaluated).
//
// Outputs (WriteVorStudy, OUT = the output folder):
//   OUT/tables/vor_results.{csv,md,tex}  one row per trial and eye (tidy, units in column names)
//   OUT/tables/vor_summary.{csv,md,tex}  per profile and eye: slip still / VOR, gain, lag, truth
//   OUT/tables/vor_frames.csv            the recording's frames (one row per frame and eye)
//   OUT/figures/vor_traces.*, vor_slip.*, vor_gain.*  (PNG, SVG, CSV, gnuplot script)
//   OUT/vor.json                         all of it, machine-readable
//   OUT/report/index.html                the page a student hands in
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fitting/vor_analysis.h"

namespace owlcal::evaluation {

// One row of vor.csv (NaN: not measured / no truth).
struct VorFrame {
  int trial = 0;
  std::string profile, condition;  // sine|step, still|vor
  double frequency_hz = 0, amplitude_deg = 0;
  int k = 0;
  double t_s = 0;
  int eye = 0;
  int neck_cmd_us = 0, pan_cmd_us = 0;
  double neck_cmd_deg = 0, pan_cmd_deg = 0;
  bool found = false;
  double x_px = NAN, y_px = NAN, gaze_err_deg = NAN, neck_deg = NAN, pan_deg = NAN;
  double true_neck_deg = NAN, true_pan_deg = NAN, true_x_px = NAN, true_y_px = NAN, true_gaze_err_deg = NAN;
};

struct VorTrialEye {
  int trial = 0;
  std::string profile, condition;
  double frequency_hz = 0, amplitude_deg = 0;
  int eye = 0;
  std::string status, reason;  // the recording's trial status, or the evaluation's
  int num_frames = 0, num_found = 0;
  fitting::SlipStats slip;
  std::optional<fitting::SlipStats> true_slip;
  fitting::VorGain gain;                      // from the frames (vor trials)
  fitting::VorGain map_gain;                  // from the commands through the maps
  std::optional<fitting::VorGain> true_gain;  // from the true joint angles
};

struct VorStudy {
  std::string source;  // dataset folder
  std::string map;     // the maps the eyes used (calibrated, or nominal)
  std::vector<VorFrame> frames;
  std::vector<VorTrialEye> results;
  int num_trials = 0, num_ok = 0;
  bool has_truth = false;
  std::vector<std::string> notes;
};

nlohmann::json VorStudyJson(const VorStudy& s);

namespace internal {
// The frames of one trial and eye, in order (for the study and its page).
std::vector<const VorFrame*> SelectVorFrames(const std::vector<VorFrame>& frames, int trial, int eye);
}  // namespace internal

}  // namespace owlcal::evaluation
