// owlcal catch-up: pursuit and catch-up saccades of a moving target (evaluation/catch_up_study.h).
// Runs the standard `catch_up` protocol on the virtual Owl (it moves the target) with the eye on
// calibrate's fitted head (--calib) or the robot file's nominal head, and evaluates it; or
// evaluates a recorded one (--dataset).
#include <iostream>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/catch_up_study.h"
#include "reports/catch_up_study_page.h"

namespace owlcal::apps {
namespace {

int RunCatchUp(const ExperimentInput& in) {
  const std::string& dir = in.dataset;
  const evaluation::CatchUpStudy study = pipeline::EvaluateCatchUpDataset(dir);
  const std::string page = reports::WriteCatchUpStudy(study, in.out, in.figures);
  std::cout << "eye on the " << study.map << "\n";
  for (const evaluation::CatchUpTrial& t : study.trials) {
    std::cout << io::FixedText(t.speed_deg_per_s, 1) << " deg/s: " << t.status;
    if (!t.reason.empty()) std::cout << " (" << t.reason << ")";
    std::cout << ", " << t.saccades << " catch-up saccades, RMS retinal error " << io::FixedText(t.rms_error_deg, 2)
              << " deg";
    if (t.saccades > 0)
      std::cout << ", |error| before " << io::FixedText(t.mean_before_deg, 2) << " -> after "
                << io::FixedText(t.mean_after_deg, 2) << " deg";
    std::cout << "\n";
  }
  std::cout << study.num_ok << " of " << study.num_trials << " trials ok";
  if (study.num_ok < study.num_trials) std::cout << " (see the report's notes)";
  std::cout << "\nreport: " << page << "\n";
  return study.num_ok == study.num_trials ? kExitOk : kExitFailed;
}

const bool kCatchUpRegistered = RegisterExperiment(
    {"catch-up",
     "Catch-up saccades (course notes: a target faster than about 30 deg/s needs them): the target moves at\n"
     "10, 20 and 30 deg/s across the eye's view (the virtual Owl moves it; a real robot cannot, and every trial\n"
     "is then a skipped row); the eye pursues with a P loop on calibrate's fitted maps (--calib; else the robot\n"
     "file's nominal maps) and makes a catch-up saccade, leading the target, when the retinal error passes the\n"
     "threshold. Counts the catch-up saccades, the retinal error before and after each and its response time,\n"
     "and the RMS error per speed (on the virtual Owl also the true error). Runs the standard `catch_up` protocol\n"
     "(or --protocol FILE), or evaluates a recording (--dataset). Writes OUT/tables/catch_up_*, OUT/figures/\n"
     "catch_up_trace.*, OUT/catch_up.json and OUT/report/index.html. Exit 1 when a trial failed.",
     "catch_up",
     "the eye moves on the robot file's NOMINAL maps",
     "",
     RunCatchUp});

}  // namespace
}  // namespace owlcal::apps
