#include "pipeline/main_sequence_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include "calib/csv.h"
#include "evaluation/study_cells.h"
#include "io/number_text.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

constexpr double kNominalAngleScaleSigma = 0.02;
constexpr double kCalibratedAngleScaleSigma = 0.003;

}  // namespace

evaluation::MainSequenceStudy EvaluateMainSequenceDataset(const std::string& dir) {
  evaluation::MainSequenceStudy s;
  s.source = dir;
  const std::string frames_csv = dir + "/main_sequence.csv", trials_csv = dir + "/main_sequence_trials.csv";
  if (!fs::exists(trials_csv))
    throw std::runtime_error(trials_csv + ": no such file (is " + dir + " a main-sequence dataset?)");
  const calib::CsvTable tt = protocols::ReadAppendedCsv(trials_csv);
  tt.RequireColumns({"saccade",
                     "amplitude_deg",
                     "repeat",
                     "direction",
                     "servo",
                     "from_us",
                     "to_us",
                     "map_amplitude_deg",
                     "phase_ms",
                     "frames",
                     "measured",
                     "map",
                     "true_slew_deg_per_s",
                     "true_lag_s",
                     "status",
                     "reason"});
  std::map<int, size_t> index;
  for (size_t r = 0; r < tt.NumRows(); ++r) {
    evaluation::MainSequenceSaccade sa;
    sa.saccade = tt.Int(r, "saccade", 0, 1000000);
    sa.amplitude_cmd_deg = tt.Number(r, "amplitude_deg", 0, 90);
    sa.repeat = tt.Int(r, "repeat", 0, 1000000);
    sa.direction = tt.Int(r, "direction", -1, 1);
    sa.servo = tt.Text(r, "servo");
    sa.from_us = tt.Text(r, "from_us").empty() ? 0 : tt.Int(r, "from_us", 0, 5000);
    sa.to_us = tt.Text(r, "to_us").empty() ? 0 : tt.Int(r, "to_us", 0, 5000);
    sa.map_amplitude_deg = evaluation::Opt(tt, r, "map_amplitude_deg");
    sa.phase_ms = evaluation::Opt(tt, r, "phase_ms");
    sa.frames = tt.Int(r, "frames", 0, 1000000);
    sa.measured = tt.Int(r, "measured", 0, 1000000);
    sa.status = tt.Text(r, "status");
    sa.reason = tt.Text(r, "reason");
    if (s.map.empty()) s.map = tt.Text(r, "map");
    if (s.servo.empty()) s.servo = sa.servo;
    const double ts = evaluation::Opt(tt, r, "true_slew_deg_per_s"), tl = evaluation::Opt(tt, r, "true_lag_s");
    if (std::isfinite(ts) && std::isfinite(tl)) {
      s.has_truth = true;
      s.true_slew_deg_per_s = ts;
      s.true_lag_s = tl;
    }
    index[sa.saccade] = s.saccades.size();
    s.saccades.push_back(sa);
  }
  s.num_saccades = int(s.saccades.size());
  if (fs::exists(frames_csv)) {
    const calib::CsvTable ft = protocols::ReadAppendedCsv(frames_csv);
    ft.RequireColumns({"saccade", "k", "t_s", "cmd_us", "found", "x_px", "y_px", "angle_deg", "true_angle_deg"});
    for (size_t r = 0; r < ft.NumRows(); ++r) {
      evaluation::MainSequenceFrame f;
      f.saccade = ft.Int(r, "saccade", 0, 1000000);
      f.k = ft.Int(r, "k", 0, 1000000);
      f.t_s = ft.Number(r, "t_s", -10, 1e6);
      f.cmd_us = ft.Int(r, "cmd_us", 0, 5000);
      f.found = ft.Int(r, "found", 0, 1) == 1;
      f.x_px = evaluation::Opt(ft, r, "x_px");
      f.y_px = evaluation::Opt(ft, r, "y_px");
      f.angle_deg = evaluation::Opt(ft, r, "angle_deg");
      f.true_angle_deg = evaluation::Opt(ft, r, "true_angle_deg");
      if (!index.count(f.saccade))
        throw std::runtime_error(ft.Where(r) + ": saccade " + std::to_string(f.saccade) + " is not in " + trials_csv);
      s.frames.push_back(f);
    }
  }
  std::sort(s.frames.begin(),
            s.frames.end(),
            [](const evaluation::MainSequenceFrame& a, const evaluation::MainSequenceFrame& b) {
              return a.saccade != b.saccade ? a.saccade < b.saccade : a.k < b.k;
            });
  // Traces of the saccades the recording calls ok.
  std::vector<fitting::SaccadeTrace> traces, true_traces;
  std::vector<size_t> which;
  bool all_true = s.has_truth;
  for (size_t i = 0; i < s.saccades.size(); ++i) {
    const evaluation::MainSequenceSaccade& sa = s.saccades[i];
    if (sa.status != "ok") continue;
    fitting::SaccadeTrace t, tt2;
    t.id = tt2.id = sa.saccade;
    for (const evaluation::MainSequenceFrame& f : s.frames)
      if (f.saccade == sa.saccade) {
        t.t_s.push_back(f.t_s);
        t.angle_deg.push_back(f.angle_deg);
        tt2.t_s.push_back(f.t_s);
        tt2.angle_deg.push_back(f.true_angle_deg);
        all_true &= std::isfinite(f.true_angle_deg);
      }
    traces.push_back(t);
    true_traces.push_back(tt2);
    which.push_back(i);
  }
  // The angles' scale: through the robot file's nominal lens (no distortion, the nominal focal
  // length) the default virtual Owl's slews came out 1.9 % large (387.2-387.5 against 380 deg/s),
  // variant A's 0.4-0.6 %; through a calibration's lens and head 0.25-0.3 % (default robot, its
  // calibrate run: 381.0 against 380). Those as sigmas: 2 % and 0.3 %.
  fitting::MainSequenceFitOptions fo;
  fo.angle_scale_sigma =
      s.map.find("nominal") != std::string::npos ? kNominalAngleScaleSigma : kCalibratedAngleScaleSigma;
  s.fit = fitting::FitMainSequence(traces, fo);
  if (all_true && !true_traces.empty()) s.truth_fit = fitting::FitMainSequence(true_traces, {});
  const double vth = s.fit.velocity_threshold_deg_per_s;
  for (size_t j = 0; j < which.size(); ++j) {
    evaluation::MainSequenceSaccade& sa = s.saccades[which[j]];
    sa.m = s.fit.saccades[j];
    if (!sa.m.ok) {
      sa.status = "failed";
      sa.reason = "not measured from its frames: " + sa.m.reason;
    }
    if (all_true && j < s.truth_fit.saccades.size() && s.truth_fit.saccades[j].ok) {
      // The true size from the true angles (their fit's amplitude), the truth's law for the rest.
      sa.true_amplitude_deg = s.truth_fit.saccades[j].amplitude_deg;
      sa.true_peak_deg_per_s = fitting::PeakVelocityDegPerS(sa.true_amplitude_deg, s.true_slew_deg_per_s, s.true_lag_s);
      sa.true_duration_s = fitting::DurationS(sa.true_amplitude_deg, s.true_slew_deg_per_s, s.true_lag_s, vth);
    }
  }
  for (const evaluation::MainSequenceSaccade& sa : s.saccades) {
    if (sa.status == "ok") {
      ++s.num_ok;
    } else {
      s.notes.push_back("saccade " + std::to_string(sa.saccade) + " (" + evaluation::Fx(sa.amplitude_cmd_deg, 1) +
                        " deg, repeat " + std::to_string(sa.repeat) + "): " + sa.status +
                        (sa.reason.empty() ? "" : ": " + sa.reason));
    }
  }
  if (s.map.find("nominal") != std::string::npos)
    s.notes.insert(s.notes.begin(),
                   "the eye moved on the robot file's NOMINAL maps (no calibration): angles are measured from the "
                   "frames through the nominal lens and head geometry");
  if (!s.fit.motion.ok) s.notes.push_back("pooled motion fit: " + s.fit.motion.message);
  if (!s.fit.peak.ok) s.notes.push_back("main-sequence fit: " + s.fit.peak.message);
  if (!s.fit.duration.ok) s.notes.push_back("duration fit: " + s.fit.duration.message);
  return s;
}

}  // namespace owlcal::pipeline
