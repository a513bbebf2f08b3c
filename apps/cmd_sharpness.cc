// owlcal sharpness: the lens-sharpness experiment (evaluation/sharpness_study.h). Runs the
// standard `sharpness` protocol on the robot (the virtual Owl by default) and evaluates it, or
// evaluates a recorded one (--dataset), or image pairs at known distances (--images CSV, e.g.
// the course's kit2020 distance set).
#include <iostream>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/sharpness_study.h"
#include "reports/sharpness_study_page.h"

namespace owlcal::apps {
namespace {

std::string Distance(double m) { return std::isfinite(m) ? io::FixedText(m, 2) + " m" : "infinity"; }

int RunSharpness(const ExperimentInput& in) {
  const evaluation::SharpnessStudy study =
      in.images.empty() ? pipeline::MeasureSharpnessDataset(in.dataset)
                        : pipeline::MeasureSharpnessPairs(pipeline::ReadSharpnessPairsCsv(in.images), in.images);
  const std::string page = reports::WriteSharpnessStudy(study, in.out, in.figures);
  for (int e = 0; e < 2; ++e) {
    const fitting::FocusFit& f = study.fit[e];
    std::cout << models::kEyeNames[e] << " eye: ";
    if (!f.ok) {
      std::cout << "no fit: " << f.reason << "\n";
      continue;
    }
    std::cout << "in-focus blur " << io::FixedText(f.s0_px, 3) << " +- " << io::FixedText(f.s0_sigma_px, 3)
              << " px, defocus " << io::FixedText(f.k_px_per_dioptre, 3) << " +- " << io::FixedText(f.k_sigma, 3)
              << " px/D";
    if (f.focus_found)
      std::cout << ", focus " << io::FixedText(f.focus_dioptre, 2) << " +- " << io::FixedText(f.focus_dioptre_sigma, 2)
                << " D (" << Distance(f.focus_m) << "), depth of field " << Distance(f.dof_near_m) << " to "
                << (f.dof_far_m > f.max_distance_m ? "beyond " + Distance(f.max_distance_m) : Distance(f.dof_far_m));
    else
      std::cout << ", focus not determined (no defocus over the range)";
    std::cout << "\n";
  }
  if (study.truth)
    std::cout << "truth: focus " << Distance(study.truth->focus_m) << ", defocus "
              << io::FixedText(study.truth->k_px_per_dioptre[0], 3) << " / "
              << io::FixedText(study.truth->k_px_per_dioptre[1], 3) << " px/D\n";
  std::cout << study.num_ok << " of " << study.num_ok + study.num_failed << " images measured";
  if (study.num_failed) std::cout << " (" << study.num_failed << " failed: see the report)";
  std::cout << "\nreport: " << page << "\n";
  return kExitOk;
}

const bool kSharpnessRegistered = RegisterExperiment(
    {"sharpness",
     "Lens sharpness against distance: the edge blur (Gaussian-equivalent sigma of isolated edges) per eye\n"
     "and distance, the fixed-focus lens's fitted focus and depth of field (blur <= sqrt 2 x the in-focus\n"
     "blur) with sigma, and on the virtual Owl its truth. Runs the standard `sharpness` protocol (a chessboard\n"
     "at 0.2-2 m) on the robot, or evaluates a recording (--dataset) or image pairs at known distances\n"
     "(--images CSV: left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h], e.g.\n"
     "data/owl-real/kit2020-distance-target1/distances.csv). Writes OUT/tables/sharpness*.{csv,md,tex},\n"
     "OUT/figures/sharpness.*, OUT/sharpness.json and OUT/report/index.html; failed images are rows with a reason.",
     "sharpness",
     "",
     "evaluate image pairs listed in this CSV (no robot)",
     RunSharpness});

}  // namespace
}  // namespace owlcal::apps
