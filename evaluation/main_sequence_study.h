#pragma once
// The saccade main-sequence experiment: a recorded `main-sequence` protocol
// (protocols/standard/main_sequence.yaml, protocols/main_sequence_step.h) evaluated from its frames
// (fitting/main_sequence_fit.h):
//   - the servo's slew, lag and the command-to-frame delay pooled over every saccade, with sigma;
//   - per saccade: amplitude, peak angular velocity and duration (time above 30 deg/s), with sigma;
//   - the main sequence: peak velocity against amplitude, V = Vmax (1 - exp(-A / C)) (Vmax = slew,
//     C = slew * lag for the servo's law), and duration against amplitude, each with sigma;
//   - on the virtual Owl: the truth's slew and lag, each estimate's error in % and in sigma, and the
//     same pooled fit on the true joint angles at the frames' exposures (what the estimator gives
//     without the image measurement).
// Every saccade is a row with its status and reason (the recording's, or why it was not measured).
//
// Outputs (WriteMainSequenceStudy, OUT = the output folder):
//   OUT/tables/main_sequence_saccades.{csv,md,tex}  one row per saccade (tidy, units in column names)
//   OUT/tables/main_sequence_summary.{csv,md,tex}   each estimate of slew and lag against the truth
//   OUT/tables/main_sequence_frames.csv             the recording's frames (one row per frame)
//   OUT/figures/main_sequence_peak.*, main_sequence_duration.*, main_sequence_traces.*
//   OUT/main_sequence.json                          all of it, machine-readable
//   OUT/report/index.html                           the page a student hands in
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fitting/main_sequence_fit.h"

namespace owlcal::evaluation {

// One row of main_sequence.csv (NaN: not measured / no truth).
struct MainSequenceFrame {
  int saccade = 0, k = 0, cmd_us = 0;
  double t_s = 0;
  bool found = false;
  double x_px = NAN, y_px = NAN, angle_deg = NAN, true_angle_deg = NAN;
};

struct MainSequenceSaccade {
  int saccade = 0, repeat = 0, direction = 0;
  double amplitude_cmd_deg = 0;  // what the protocol asked for
  std::string servo;
  int from_us = 0, to_us = 0;  // 0: not sent
  double map_amplitude_deg = NAN, phase_ms = NAN;
  int frames = 0, measured = 0;
  std::string status, reason;     // the recording's, or the evaluation's
  fitting::SaccadeMeasurement m;  // from the frames
  double true_amplitude_deg = NAN, true_peak_deg_per_s = NAN, true_duration_s = NAN;
};

struct MainSequenceStudy {
  std::string source, map, servo;
  std::vector<MainSequenceFrame> frames;
  std::vector<MainSequenceSaccade> saccades;
  fitting::MainSequenceFit fit;        // from the frames
  fitting::MainSequenceFit truth_fit;  // the same fit on the true angles (virtual Owl)
  bool has_truth = false;
  double true_slew_deg_per_s = NAN, true_lag_s = NAN;
  int num_saccades = 0, num_ok = 0;
  std::vector<std::string> notes;
};

nlohmann::json MainSequenceStudyJson(const MainSequenceStudy& s);

}  // namespace owlcal::evaluation
