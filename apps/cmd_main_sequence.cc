// owlcal main-sequence: the saccade main-sequence experiment (evaluation/main_sequence_study.h).
// Runs the standard `main-sequence` protocol on the robot (the virtual Owl by default) with the
// eye on calibrate's fitted head (--calib) or the robot file's nominal head, and evaluates it; or
// evaluates a recorded one (--dataset).
#include <iostream>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/main_sequence_study.h"
#include "reports/main_sequence_study_page.h"

namespace owlcal::apps {
namespace {

int RunMainSequence(const ExperimentInput& in) {
  const std::string& dir = in.dataset;
  const evaluation::MainSequenceStudy study = pipeline::EvaluateMainSequenceDataset(dir);
  const std::string page = reports::WriteMainSequenceStudy(study, in.out, in.figures);
  const fitting::MainSequenceFit& f = study.fit;
  std::cout << "eye on the " << study.map << "\n";
  std::cout << "pooled motion of " << study.servo << ": " << f.motion.message << "\n";
  std::cout << "main sequence (peak velocity): "
            << (f.peak.ok ? "slew " + io::FixedText(f.peak.vmax_deg_per_s, 1) + " +- " +
                                io::FixedText(f.peak.vmax_sigma_deg_per_s, 1) + " deg/s, lag " +
                                io::FixedText(1000 * f.peak.lag_s, 2) + " +- " +
                                io::FixedText(1000 * f.peak.lag_sigma_s, 2) + " ms"
                          : f.peak.message)
            << "\n";
  std::cout << "durations: " << f.duration.message << "\n";
  if (study.has_truth)
    std::cout << "truth: slew " << io::FixedText(study.true_slew_deg_per_s, 1) << " deg/s, lag "
              << io::FixedText(1000 * study.true_lag_s, 2) << " ms\n";
  std::cout << study.num_ok << " of " << study.num_saccades << " saccades ok";
  if (study.num_ok < study.num_saccades) std::cout << " (see the report's notes)";
  std::cout << "\nreport: " << page << "\n";
  return study.num_ok == study.num_saccades && f.peak.ok ? kExitOk : kExitFailed;
}

const bool kMainSequenceRegistered = RegisterExperiment(
    {"main-sequence",
     "The saccade main sequence: the eye's pan makes saccades of 2-40 deg across a fixation disc, each command\n"
     "at a different phase of the frame clock, on calibrate's fitted maps (--calib) or the robot file's nominal\n"
     "maps (the report says so). From the frames (the eye's angle from the disc's pixel) it fits the servo's slew,\n"
     "lag and the command-to-frame delay over all saccades, each saccade's amplitude, peak angular velocity and\n"
     "duration, and the main sequence V = Vmax (1 - exp(-A / C)) and duration against amplitude, with sigma; on\n"
     "the virtual Owl also the truth. Runs the standard `main_sequence` protocol (or --protocol FILE) on the robot,\n"
     "or evaluates a recording (--dataset). Writes OUT/tables/main_sequence_*.{csv,md,tex},\n"
     "OUT/figures/main_sequence_*, OUT/main_sequence.json and OUT/report/index.html; every saccade is a row with\n"
     "its status. Exit 1 when a saccade failed or the main sequence could not be fitted.",
     "main_sequence",
     "the eye moves on the robot file's NOMINAL maps (angles from its nominal lens)",
     "",
     RunMainSequence});

}  // namespace
}  // namespace owlcal::apps
