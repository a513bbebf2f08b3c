// owlcal vor: the vestibulo-ocular reflex experiment (evaluation/vor_study.h). Runs the standard
// `vor` protocol on the robot (the virtual Owl by default) with the eyes on calibrate's fitted
// head (--calib) or the robot file's nominal head, and evaluates it; or evaluates a recorded one
// (--dataset).
#include <iostream>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/vor_study.h"
#include "reports/vor_study_page.h"

namespace owlcal::apps {
namespace {

int RunVor(const ExperimentInput& in) {
  const std::string& dir = in.dataset;
  const evaluation::VorStudy study = pipeline::EvaluateVorDataset(dir);
  const std::string page = reports::WriteVorStudy(study, in.out, in.figures);
  std::cout << "eyes on the " << study.map << "\n";
  for (const evaluation::VorTrialEye& r : study.results) {
    if (r.condition != "vor") continue;
    std::cout << r.profile << " " << io::FixedText(r.amplitude_deg, 1) << " deg";
    if (r.profile == "sine") std::cout << " at " << io::FixedText(r.frequency_hz, 2) << " Hz";
    std::cout << ", " << models::kEyeNames[r.eye] << " eye: ";
    if (r.status != "ok") std::cout << r.status << " (" << r.reason << ") ";
    if (r.gain.ok) {
      std::cout << "gain " << io::FixedText(r.gain.gain, 3) << " +- " << io::FixedText(r.gain.gain_sigma, 3);
      if (r.profile == "sine")
        std::cout << ", lag " << io::FixedText(r.gain.lag_deg, 1) << " +- " << io::FixedText(r.gain.lag_sigma_deg, 1)
                  << " deg";
      if (r.true_gain && r.true_gain->ok) std::cout << " (truth " << io::FixedText(r.true_gain->gain, 3) << ")";
    } else {
      std::cout << "gain not measured: " << r.gain.reason;
    }
    std::cout << "; RMS slip " << io::FixedText(r.slip.rms_deg_per_s, 2) << " deg/s\n";
  }
  std::cout << study.num_ok << " of " << study.num_trials << " trials ok";
  if (study.num_ok < study.num_trials) std::cout << " (see the report's notes)";
  std::cout << "\nreport: " << page << "\n";
  return study.num_ok == study.num_trials ? kExitOk : kExitFailed;
}

const bool kVorRegistered = RegisterExperiment(
    {"vor",
     "The vestibulo-ocular reflex: the neck turns through sines at 0.2-1 Hz and a step, once with the eyes\n"
     "held still and once with the eyes counter-rotating on the calibrated neck and eye-pan maps (--calib: a\n"
     "calibrate output folder; without it the robot file's nominal maps, and the report says so). Measures the\n"
     "target's image slip (px, px/s, deg/s; RMS and peak) against the still run, and the VOR gain and phase lag\n"
     "from sines fitted to the eye and neck angles measured from the frames, with sigma; on the virtual Owl also\n"
     "the truth. Runs the standard `vor` protocol (or --protocol FILE) on the robot, or evaluates a recording\n"
     "(--dataset). Writes OUT/tables/vor_*.{csv,md,tex}, OUT/figures/vor_*, OUT/vor.json and OUT/report/index.html;\n"
     "every trial is a row with its status. Exit 1 when a trial failed.",
     "vor",
     "the eyes counter-rotate on the robot file's NOMINAL maps",
     "",
     RunVor});

}  // namespace
}  // namespace owlcal::apps
