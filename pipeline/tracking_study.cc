#include "pipeline/tracking_study.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

int EyeIndex(const calib::CsvTable& t, size_t r) {
  const std::string eye = t.Text(r, "eye");
  if (eye != models::kEyeNames[0] && eye != models::kEyeNames[1])
    throw std::runtime_error(t.Where(r) + ": eye '" + eye + "' is neither left nor right");
  return eye == models::kEyeNames[0] ? 0 : 1;
}

// A reason without its numbers (positions, errors), so that equal causes count together.
std::string ReasonKind(const std::string& reason) {
  std::string out;
  bool in_number = false;
  for (char c : reason) {
    const bool num = std::isdigit(static_cast<unsigned char>(c)) || ((c == '.' || c == '-') && in_number);
    if (num) {
      if (!in_number) out += '#';
      in_number = true;
      continue;
    }
    in_number = false;
    out += c;
  }
  return out;
}

// The trials of track_trials.csv: status and reason per run into s, a note per run not ok.
void ReadTrackTrials(const std::string& path, evaluation::TrackingStudy* s) {
  const calib::CsvTable tt = protocols::ReadAppendedCsv(path);
  tt.RequireColumns({"frames", "status", "reason"});
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    s->trial_status.push_back(tt.Text(r, "status"));
    s->trial_reason.push_back(tt.Text(r, "reason"));
    if (s->trial_status.back() != "ok")
      s->notes.push_back("tracking run " + std::to_string(r) + ": " + s->trial_status.back() + ": " +
                         s->trial_reason.back());
  }
}

// One row of track.csv, checked (status one of ok, reacquired, lost and agreeing with found).
evaluation::TrackFrame TrackFrameOfRow(const calib::CsvTable& t, size_t r) {
  evaluation::TrackFrame f;
  f.step_index = t.Int(r, "step_index", 0, 1000000);
  f.phase = t.Text(r, "phase");
  f.k = t.Int(r, "k", 0, 100000000);
  f.t_s = t.Number(r, "t_s", -1e6, 1e6);
  f.eye = EyeIndex(t, r);
  f.tracker = t.Text(r, "tracker");
  f.pan_cmd_us = t.Int(r, "pan_cmd_us", 0, 9999);
  f.tilt_cmd_us = t.Int(r, "tilt_cmd_us", 0, 9999);
  f.status = t.Text(r, "status");
  if (f.status != "ok" && f.status != "reacquired" && f.status != "lost")
    throw std::runtime_error(t.Where(r) + ": status '" + f.status + "' is not ok, reacquired or lost");
  f.found = t.Int(r, "found", 0, 1) == 1;
  if (f.found != (f.status != "lost"))
    throw std::runtime_error(t.Where(r) + ": found " + std::to_string(f.found) + " disagrees with status " + f.status);
  f.x_px = evaluation::Opt(t, r, "x_px");
  f.y_px = evaluation::Opt(t, r, "y_px");
  f.reason = t.Text(r, "reason");
  f.true_x_px = evaluation::Opt(t, r, "true_x_px");
  f.true_y_px = evaluation::Opt(t, r, "true_y_px");
  f.true_in_view = t.Text(r, "true_in_view").empty() ? -1 : t.Int(r, "true_in_view", 0, 1);
  if (f.found && std::isfinite(f.true_x_px)) f.error_px = std::hypot(f.x_px - f.true_x_px, f.y_px - f.true_y_px);
  return f;
}

// The frames of track.csv.
std::vector<evaluation::TrackFrame> ReadTrackFrames(const std::string& path) {
  const calib::CsvTable t = protocols::ReadAppendedCsv(path);
  t.RequireColumns({"step_index",
                    "phase",
                    "k",
                    "t_s",
                    "eye",
                    "tracker",
                    "pan_cmd_us",
                    "tilt_cmd_us",
                    "status",
                    "found",
                    "x_px",
                    "y_px",
                    "reason",
                    "true_x_px",
                    "true_y_px",
                    "true_in_view"});
  std::vector<evaluation::TrackFrame> frames;
  for (size_t r = 0; r < t.NumRows(); ++r) frames.push_back(TrackFrameOfRow(t, r));
  return frames;
}

// Per tracker and eye, in the order they first appear: counts, lost reasons and the pixel error
// in view; a note per tracker that lost the target in view or gave a position out of view.
std::vector<evaluation::TrackerSummary> SummariseTrackers(const std::vector<evaluation::TrackFrame>& frames,
                                                          std::vector<std::string>* notes) {
  std::vector<evaluation::TrackerSummary> summaries;
  for (const evaluation::TrackFrame& f : frames) {
    auto same = [&](const evaluation::TrackerSummary& t) { return t.tracker == f.tracker && t.eye == f.eye; };
    if (std::find_if(summaries.begin(), summaries.end(), same) == summaries.end()) {
      evaluation::TrackerSummary ts;
      ts.tracker = f.tracker;
      ts.eye = f.eye;
      summaries.push_back(ts);
    }
    evaluation::TrackerSummary& ts = *std::find_if(summaries.begin(), summaries.end(), same);
    ++ts.num_frames;
    ts.num_found += f.found ? 1 : 0;
    ts.num_reacquired += f.status == "reacquired" ? 1 : 0;
    if (!f.found) {
      ++ts.num_lost;
      ++ts.lost_reasons[ReasonKind(f.reason)];
    }
    if (f.true_in_view == 1) {
      ++ts.num_in_view;
      if (!f.found) ++ts.num_lost_in_view;
    }
    if (f.true_in_view == 0 && f.found) ++ts.num_found_out_of_view;
  }
  for (evaluation::TrackerSummary& ts : summaries) {
    double sum2 = 0, mx = 0;
    for (const evaluation::TrackFrame& f : frames) {
      if (f.tracker != ts.tracker || f.eye != ts.eye || f.true_in_view != 1 || !std::isfinite(f.error_px)) continue;
      ++ts.num_errors;
      sum2 += f.error_px * f.error_px;
      mx = std::max(mx, f.error_px);
      if (f.error_px > evaluation::kOffTargetPx) ++ts.num_off_target;
    }
    if (ts.num_errors > 0) {
      ts.rms_px = std::sqrt(sum2 / ts.num_errors);
      ts.max_px = mx;
    }
    if (ts.num_lost_in_view > 0)
      notes->push_back(ts.tracker + " tracker, " + models::kEyeNames[ts.eye] + " eye: lost in " +
                       std::to_string(ts.num_lost_in_view) + " of " + std::to_string(ts.num_in_view) +
                       " frames with the target in view");
    if (ts.num_found_out_of_view > 0)
      notes->push_back(ts.tracker + " tracker, " + models::kEyeNames[ts.eye] + " eye: gave a position in " +
                       std::to_string(ts.num_found_out_of_view) +
                       " frames with the target out of view (locked on something else)");
  }
  return summaries;
}

// The salience candidates of salience.csv into s, with how many lie on an object and were
// fixated, and a note per candidate whose fixation was not ok.
void ReadSalience(const std::string& path, evaluation::TrackingStudy* s) {
  const calib::CsvTable t = protocols::ReadAppendedCsv(path);
  t.RequireColumns(evaluation::kSalienceRowColumns);
  for (size_t r = 0; r < t.NumRows(); ++r) {
    evaluation::SalienceRow c;
    c.rank = t.Int(r, "rank", 1, 1000);
    c.x_px = t.Number(r, "x_px");
    c.y_px = t.Number(r, "y_px");
    c.score = t.Number(r, "score");
    c.intensity = t.Number(r, "intensity");
    c.colour = t.Number(r, "colour");
    c.orientation = t.Number(r, "orientation");
    c.object = t.Text(r, "object");
    c.object_distance_px = evaluation::Opt(t, r, "object_distance_px");
    c.object_radius_px = evaluation::Opt(t, r, "object_radius_px");
    c.fix_status = t.Text(r, "fix_status");
    c.fix_reason = t.Text(r, "fix_reason");
    c.fix_iterations = t.Int(r, "fix_iterations", 0, 100000);
    c.fix_dx_px = evaluation::Opt(t, r, "fix_dx_px");
    c.fix_dy_px = evaluation::Opt(t, r, "fix_dy_px");
    c.fixated_object = t.Text(r, "fixated_object");
    c.fixated_distance_px = evaluation::Opt(t, r, "fixated_distance_px");
    s->num_on_object += c.object.empty() ? 0 : 1;
    s->num_fixated += c.fix_status == "ok" ? 1 : 0;
    if (c.fix_status != "ok")
      s->notes.push_back("salience candidate " + std::to_string(c.rank) + ": fixation " + c.fix_status + ": " +
                         c.fix_reason);
    s->salience.push_back(c);
  }
}

}  // namespace

evaluation::TrackingStudy EvaluateTrackingDataset(const std::string& dir) {
  evaluation::TrackingStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/track.csv", trials_csv = dir + "/track_trials.csv";
  if (!fs::exists(trials_csv))
    throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a track dataset?)");
  ReadTrackTrials(trials_csv, &s);
  if (fs::exists(frames_csv)) {
    s.frames = ReadTrackFrames(frames_csv);
    for (const evaluation::TrackFrame& f : s.frames)
      if (f.true_in_view >= 0) s.has_truth = true;
  } else {
    s.notes.push_back(frames_csv + " does not exist: no frame was logged");
  }
  s.summaries = SummariseTrackers(s.frames, &s.notes);
  const std::string sal_csv = dir + "/salience.csv";
  if (fs::exists(sal_csv)) ReadSalience(sal_csv, &s);
  const std::string map_csv = dir + "/salience_map.csv";
  if (fs::exists(map_csv)) {
    const calib::CsvTable t = protocols::ReadAppendedCsv(map_csv);
    t.RequireColumns({"x_px", "y_px", "salience"});
    for (size_t r = 0; r < t.NumRows(); ++r)
      s.salience_map.push_back({t.Number(r, "x_px"), t.Number(r, "y_px"), t.Number(r, "salience")});
  }
  if (!s.has_truth) s.notes.push_back("no truth: a real robot (the virtual Owl logs the target's true pixel)");
  return s;
}

}  // namespace owlcal::pipeline
