// owlcal range-images DIR --calib FILE [--truth CSV] --out OUT: range a target in stereo pairs,
// at known distances (error against the truth, datum and scale fit) or unknown ones (range with
// sigma), every row with a status (ok, low_confidence, failed). pipeline/range_images.h runs it.
#include <iostream>
#include <memory>
#include <stdexcept>

#include "apps/command_registry.h"
#include "pipeline/range_images.h"

namespace owlcal::apps {
namespace {

int RunRangeImages(const pipeline::RangeImagesRunOptions& a) {
  std::string why;
  if (!a.Check(&why)) throw UsageError(why);
  pipeline::RangeImagesRun run;
  try {
    run = pipeline::RunRangeImages(a, [](const std::string& line) { std::cerr << line << "\n"; });
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  if (!run.figure_error.empty()) std::cerr << "figure not drawn: " << run.figure_error << "\n";
  std::cout << run.markdown << "wrote " << a.out << ": ranges.md ranges.csv "
            << (run.datum.ok ? "scale_budget.json " : "") << run.figure << ".{csv,gp"
            << (run.figure_drawn ? ",png,svg" : "") << "}\n";
  return run.summary.num_failed == 0 && run.summary.num_low_confidence == 0 ? kExitOk : kExitFailed;
}

const bool kRangeImagesRegistered = RegisterCommand(
    "range-images",
    "Range a target in stereo pairs: rectify with a calibration (results.json, calibration.yaml or the\n"
    "course's intrinsics.xml + extrinsics.xml), match a template from the left image along the rectified row\n"
    "(NCC, sub-pixel, left-right check, second-peak ratio, texture, depth-consistency of its quarters),\n"
    "triangulate, predict sigma (matching, calibration covariance and the calibration's two halves). Each row\n"
    "has a status: ok, low_confidence (ranged, flagged, not counted) or failed. With --truth\n"
    "(left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h]; blank = unknown) the errors, and a fit of the truth's\n"
    "datum and scale (distance = a + b truth) with the errors before and after it. Without --truth every\n"
    "left*/right* pair of DIR is ranged. Writes ranges.md, ranges.csv and a figure. Exit 1 if any row is not ok.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<pipeline::RangeImagesRunOptions>();
      cmd->add_option("dir", o->dir, "folder of the image pairs")->required()->check(CLI::ExistingDirectory);
      cmd->add_option("--calib", o->calib, "calibration file or folder")->required();
      cmd->add_option("--truth", o->truth, "truth CSV (optional: without it every pair is ranged, distance unknown)")
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--roi", o->roi, "template x y w h in the left rectified image")->expected(4);
      cmd->add_option("--select",
                      o->select,
                      "how to choose the template when no ROI is given: centre (the central region), texture (the most "
                      "textured windows near the centre, first confident one), colour:red|green|blue|yellow (the blob "
                      "nearest the centre), tag or tag:ID (an AprilTag)")
          ->capture_default_str();
      cmd->add_option("--template-size", o->template_w, "template width [px]")->capture_default_str();
      cmd->add_option("--template-height", o->template_h, "template height [px]")->capture_default_str();
      cmd->add_option("--max-disparity", o->max_disparity, "largest disparity searched [px]")->capture_default_str();
      cmd->add_option("--truth-sigma-cm", o->truth_sigma_cm, "uncertainty of the logged distances [cm]")
          ->capture_default_str();
      cmd->add_option("--datum-cm", o->datum_cm, "added to the depth from the optical centres [cm]")
          ->capture_default_str();
      cmd->add_flag("--no-datum-fit", o->no_datum_fit, "do not fit the truth's datum and scale");
      cmd->add_flag("--mirror", o->mirror, "flip each image horizontally first (mirrored captures)");
      return [o] { return RunRangeImages(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
