#pragma once
// The catch-up saccade experiment: a recorded `catch-up` protocol (protocols/standard/catch_up.yaml,
// protocols/catch_up_step.h) evaluated per trial and per catch-up saccade:
//   - per saccade: the retinal error in the frame that triggered it (before), in the first frame
//     the controller used after it (after), and its response time (from the command to the first
//     frame whose error is below half of the error before; empty when none came before the next
//     saccade or the trial's end);
//   - per trial (one target speed): the number of catch-up saccades, the RMS retinal error while
//     the target moved (measured, and on the virtual Owl the truth's), the mean |error| before and
//     after the saccades, the median response time.
// Every trial is a row with its status and reason.
//
// Outputs (WriteCatchUpStudy, OUT = the output folder):
//   OUT/tables/catch_up_trials.{csv,md,tex}    one row per trial
//   OUT/tables/catch_up_saccades.{csv,md,tex}  one row per catch-up saccade
//   OUT/tables/catch_up_frames.csv             one row per frame
//   OUT/figures/catch_up_trace.*               retinal error of the fastest trial, saccades marked
//   OUT/catch_up.json, OUT/report/index.html
#include <array>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace owlcal::evaluation {

// The columns of catch_up.csv (protocols/catch_up_step.h), one frame each: what the reader
// requires and the frames table repeats.
inline constexpr std::array<const char*, 12> kCatchUpFrameColumns = {"trial",
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
                                                                     "action"};

struct CatchUpFrame {
  int trial = 0, direction = 0, k = 0, cmd_us = 0;
  double speed_deg_per_s = 0, t_s = 0, target_az_deg = 0;
  bool found = false;
  double x_px = NAN, error_deg = NAN, true_error_deg = NAN;
  std::string action;
};

struct CatchUpSaccade {
  int trial = 0, k = 0;
  double speed_deg_per_s = 0, t_s = 0;
  double error_before_deg = NAN, error_after_deg = NAN, true_error_before_deg = NAN, true_error_after_deg = NAN;
  double response_ms = NAN;
};

struct CatchUpTrial {
  int trial = 0, direction = 0, frames = 0, found = 0, saccades = 0;
  double speed_deg_per_s = 0;
  std::string status, reason;
  double rms_error_deg = NAN, true_rms_error_deg = NAN;  // while the target moved
  double mean_before_deg = NAN, mean_after_deg = NAN, median_response_ms = NAN;
};

struct CatchUpStudy {
  std::string source, map;
  std::vector<CatchUpFrame> frames;
  std::vector<CatchUpTrial> trials;
  std::vector<CatchUpSaccade> saccades;
  bool has_truth = false;
  int num_trials = 0, num_ok = 0;
  std::vector<std::string> notes;
};

nlohmann::json CatchUpStudyJson(const CatchUpStudy& s);

}  // namespace owlcal::evaluation
