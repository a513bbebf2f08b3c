#include "pipeline/catch_up_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/statistics.h"
#include "protocols/dataset.h"

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

evaluation::CatchUpStudy EvaluateCatchUpDataset(const std::string& dir) {
  evaluation::CatchUpStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/catch_up.csv", trials_csv = dir + "/catch_up_trials.csv";
  if (!fs::exists(trials_csv))
    throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a catch-up dataset?)");
  const calib::CsvTable tt = protocols::ReadAppendedCsv(trials_csv);
  tt.RequireColumns(
      {"trial", "speed_deg_per_s", "direction", "frames", "found", "saccades", "map", "status", "reason"});
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    evaluation::CatchUpTrial t;
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
    ft.RequireColumns(evaluation::kCatchUpFrameColumns);
    for (size_t r = 0; r < ft.NumRows(); ++r) {
      evaluation::CatchUpFrame f;
      f.trial = ft.Int(r, "trial", 0, 1000000);
      f.speed_deg_per_s = ft.Number(r, "speed_deg_per_s", 0, 1000);
      f.direction = ft.Int(r, "direction", -1, 1);
      f.k = ft.Int(r, "k", 0, 10000000);
      f.t_s = ft.Number(r, "t_s", -10, 1e6);
      f.target_az_deg = ft.Number(r, "target_az_deg", -360, 360);
      f.cmd_us = ft.Int(r, "cmd_us", 0, 5000);
      f.found = ft.Int(r, "found", 0, 1) == 1;
      f.x_px = evaluation::Opt(ft, r, "x_px");
      f.error_deg = evaluation::Opt(ft, r, "error_deg");
      f.true_error_deg = evaluation::Opt(ft, r, "true_error_deg");
      f.action = ft.Text(r, "action");
      s.has_truth |= std::isfinite(f.true_error_deg);
      s.frames.push_back(f);
    }
  }
  std::stable_sort(
      s.frames.begin(), s.frames.end(), [](const evaluation::CatchUpFrame& a, const evaluation::CatchUpFrame& b) {
        return a.trial != b.trial ? a.trial < b.trial : a.k < b.k;
      });
  for (evaluation::CatchUpTrial& t : s.trials) {
    std::vector<const evaluation::CatchUpFrame*> fr;
    for (const evaluation::CatchUpFrame& f : s.frames)
      if (f.trial == t.trial) fr.push_back(&f);
    if (fr.empty()) continue;
    const double az_end = fr.back()->target_az_deg;
    double ss = 0, tss = 0;
    int n = 0, tn = 0;
    std::vector<double> before, after, response;
    for (size_t i = 0; i < fr.size(); ++i) {
      const evaluation::CatchUpFrame& f = *fr[i];
      if (std::abs(f.target_az_deg - az_end) > 1e-6) {  // the target still moving
        if (std::isfinite(f.error_deg)) ss += f.error_deg * f.error_deg, ++n;
        if (std::isfinite(f.true_error_deg)) tss += f.true_error_deg * f.true_error_deg, ++tn;
      }
      if (f.action != "saccade") continue;
      evaluation::CatchUpSaccade c;
      c.trial = t.trial;
      c.k = f.k;
      c.speed_deg_per_s = t.speed_deg_per_s;
      c.t_s = f.t_s;
      c.error_before_deg = f.error_deg;
      c.true_error_before_deg = f.true_error_deg;
      for (size_t j = i + 1; j < fr.size(); ++j) {
        const evaluation::CatchUpFrame& g = *fr[j];
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
    for (const evaluation::CatchUpFrame* f : fr)
      if (std::isfinite(f->error_deg) && std::isfinite(f->true_error_deg))
        gap.push_back(std::abs(f->error_deg - f->true_error_deg));
    const int off = int(std::count_if(gap.begin(), gap.end(), [](double g) { return g > kOffTargetDeg; }));
    if (t.status == "ok" && off >= 3) {
      t.status = "off target";
      t.reason = "the eye tracked something else: the measured retinal error left the truth by more than " +
                 evaluation::Fx(kOffTargetDeg, 1) + " deg in " + std::to_string(off) + " of " +
                 std::to_string(gap.size()) + " frames (median " + evaluation::Fx(models::Median(gap), 2) + ", up to " +
                 evaluation::Fx(*std::max_element(gap.begin(), gap.end()), 1) + " deg)";
    }
    t.mean_before_deg = Mean(before);
    t.mean_after_deg = Mean(after);
    t.median_response_ms = response.empty() ? NAN : models::Median(response);
  }
  s.num_trials = int(s.trials.size());
  for (const evaluation::CatchUpTrial& t : s.trials) {
    if (t.status == "ok")
      ++s.num_ok;
    else
      s.notes.push_back("trial " + std::to_string(t.trial) + " (" + evaluation::Fx(t.speed_deg_per_s, 1) +
                        " deg/s): " + t.status + (t.reason.empty() ? "" : ": " + t.reason));
  }
  if (s.map.find("nominal") != std::string::npos)
    s.notes.insert(s.notes.begin(), "the eye moved on the robot file's NOMINAL maps (no calibration)");
  return s;
}

}  // namespace owlcal::pipeline
