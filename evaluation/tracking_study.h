#pragma once
// Salience targets and tracking (issue 16 item 3): a recorded `track` protocol
// (protocols/standard/track.yaml, protocols/track_step.h) evaluated against the virtual Owl's truth:
//   - per tracker (the fixation locator and Lucas-Kanade) and eye: frames, how often the track was
//     lost (n lost of N, with the reasons counted), reacquired, found while the target was out of
//     view, and the pixel error against the target's true projected pixel (RMS and max over every
//     frame it gave a position with the target in view; off target = error > kOffTargetPx);
//   - per salience candidate: rank, pixel, score, the scene object it lies on (truth) and the pixel
//     distance to that object's centre, and how its fixation went; the hit rate (candidates on an
//     object) and whether the top candidate is on one.
//
// Outputs (WriteTrackingStudy, OUT = the output folder):
//   OUT/tables/track_summary.{csv,md,tex}    one row per tracker and eye
//   OUT/tables/track_lost.{csv,md,tex}       lost-track reasons per tracker and eye, counted
//   OUT/tables/salience_candidates.{csv,md,tex}
//   OUT/tables/track_frames.csv              one row per frame, eye and tracker (tidy, for a spreadsheet)
//   OUT/figures/track_error.*, salience_map.*   (PNG, SVG, CSV, gnuplot script)
//   OUT/track.json, OUT/report/index.html
#include <array>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace owlcal::evaluation {

inline constexpr double kOffTargetPx = 3.0;

struct TrackFrame {
  int step_index = 0;
  std::string phase;  // figure8 | leave | return
  int k = 0;
  double t_s = 0;
  int eye = 0;
  std::string tracker;  // fixation | lk
  int pan_cmd_us = 0, tilt_cmd_us = 0;
  std::string status;  // ok | reacquired | lost
  bool found = false;
  double x_px = NAN, y_px = NAN;
  std::string reason;
  double true_x_px = NAN, true_y_px = NAN;
  int true_in_view = -1;  // 1, 0, -1 = no truth
  double error_px = NAN;  // |tracked - true| when both exist
};

struct TrackerSummary {
  std::string tracker;
  int eye = 0;
  int num_frames = 0, num_found = 0, num_lost = 0, num_reacquired = 0;
  int num_in_view = 0;            // frames with the target's true pixel in the image
  int num_lost_in_view = 0;       // lost although the target was in view
  int num_found_out_of_view = 0;  // a position although the target was out of view (a false lock)
  int num_errors = 0;             // frames with a position and the target in view (the error's sample)
  int num_off_target = 0;         // of those, error > kOffTargetPx
  double rms_px = NAN, max_px = NAN;
  std::map<std::string, int> lost_reasons;  // reason (numbers removed) -> frames
};

// The columns of salience.csv (protocols/track_step.h) a SalienceRow holds, in its order: what the
// study reads and what the salience_candidates table shows.
inline constexpr std::array<const char*, 17> kSalienceRowColumns = {"rank",
                                                                    "x_px",
                                                                    "y_px",
                                                                    "score",
                                                                    "intensity",
                                                                    "colour",
                                                                    "orientation",
                                                                    "object",
                                                                    "object_distance_px",
                                                                    "object_radius_px",
                                                                    "fix_status",
                                                                    "fix_reason",
                                                                    "fix_iterations",
                                                                    "fix_dx_px",
                                                                    "fix_dy_px",
                                                                    "fixated_object",
                                                                    "fixated_distance_px"};

struct SalienceRow {
  int rank = 0;
  double x_px = 0, y_px = 0, score = 0, intensity = 0, colour = 0, orientation = 0;
  std::string object;  // the object it lies on ("" none)
  double object_distance_px = NAN, object_radius_px = NAN;
  std::string fix_status, fix_reason;
  int fix_iterations = 0;
  double fix_dx_px = NAN, fix_dy_px = NAN;
  std::string fixated_object;
  double fixated_distance_px = NAN;
};

struct TrackingStudy {
  std::string source;
  std::vector<TrackFrame> frames;
  std::vector<TrackerSummary> summaries;
  std::vector<std::string> trial_status, trial_reason;  // track_trials.csv rows
  std::vector<SalienceRow> salience;
  std::vector<std::array<double, 3>> salience_map;  // x_px, y_px, value
  bool has_truth = false;
  int num_on_object = 0;  // salience candidates on a scene object
  int num_fixated = 0;    // candidates whose fixation ended ok
  std::vector<std::string> notes;

  const TrackerSummary* Find(const std::string& tracker, int eye) const;
};

nlohmann::json TrackingStudyJson(const TrackingStudy& s);

}  // namespace owlcal::evaluation
