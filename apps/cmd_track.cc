// owlcal track: salience targets and tracking (evaluation/tracking_study.h). Runs the standard `track`
// protocol on the robot (the virtual Owl by default) and evaluates it, or evaluates a recorded one
// (--dataset).
#include <iostream>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/tracking_study.h"
#include "reports/tracking_study_page.h"

namespace owlcal::apps {
namespace {

int RunTrack(const ExperimentInput& in) {
  const std::string& dir = in.dataset;
  const evaluation::TrackingStudy study = pipeline::EvaluateTrackingDataset(dir);
  const std::string page = reports::WriteTrackingStudy(study, in.out, in.figures);
  for (const evaluation::TrackerSummary& t : study.summaries) {
    std::cout << t.tracker << ", " << models::kEyeNames[t.eye] << " eye: " << t.num_lost << " of " << t.num_frames
              << " frames lost (" << t.num_lost_in_view << " with the target in view), " << t.num_reacquired
              << " reacquired";
    if (t.num_errors > 0)
      std::cout << "; error RMS " << io::FixedText(t.rms_px, 3) << " px, max " << io::FixedText(t.max_px, 3)
                << " px over " << t.num_errors << " frames (" << t.num_off_target << " off target)";
    std::cout << "\n";
  }
  if (!study.salience.empty()) {
    std::cout << "salience: " << study.num_on_object << " of " << study.salience.size()
              << " candidates on a scene object, " << study.num_fixated << " fixated";
    const evaluation::SalienceRow& top = study.salience.front();
    std::cout << "; top candidate at (" << io::FixedText(top.x_px, 1) << ", " << io::FixedText(top.y_px, 1) << ") "
              << (top.object.empty() ? "on no object" : "on " + top.object) << "\n";
  }
  bool ok = true;
  for (const std::string& st : study.trial_status) ok = ok && st == "ok";
  for (const std::string& n : study.notes) std::cout << "note: " << n << "\n";
  std::cout << "report: " << page << "\n";
  return ok ? kExitOk : kExitFailed;
}

const bool kTrackRegistered = RegisterExperiment(
    {"track",
     "Salience targets and tracking (course notes: Itti & Koch's salience model, Lucas-Kanade tracking in\n"
     "Annex 7): a salience map of the right eye (intensity, colour and orientation difference-of-Gaussians\n"
     "channels) picks the next fixation targets and the right eye fixates each with a Lucas-Kanade tracker;\n"
     "then the eyes move through a figure of eight and look away while the target is tracked in both eyes by\n"
     "the fixation locator and by LK (pyramidal calcOpticalFlowPyrLK with a forward-backward check). On the\n"
     "virtual Owl every tracked pixel is compared with the target's true pixel: error RMS and max, and how\n"
     "often track is lost (n of N, with reasons); every salience candidate with the scene object it lies on.\n"
     "Runs the standard `track` protocol (or --protocol FILE) on the robot, or evaluates a recording\n"
     "(--dataset). Writes OUT/tables/track_*.{csv,md,tex}, salience_candidates, track_frames.csv,\n"
     "OUT/figures/track_error.*, salience_map.*, OUT/track.json and OUT/report/index.html. Exit 1 when the\n"
     "tracking run stopped early.",
     "track",
     "",
     "",
     RunTrack});

}  // namespace
}  // namespace owlcal::apps
