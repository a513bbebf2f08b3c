// owlcal depth: dense disparity and depth from stereo pairs with a calibration (the course's
// stereo_match exercise; pipeline/depth.h runs it, reports/depth_files.h lists what it writes).
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "pipeline/depth.h"

namespace owlcal::apps {
namespace {

int RunDepth(const pipeline::DepthRunOptions& a) {
  std::string why;
  if (!a.Check(&why)) throw UsageError(why);
  const pipeline::DepthRun run = pipeline::RunDepth(a, [](const std::string& line) { std::cout << line << "\n"; });
  if (!run.truth_md.empty()) std::cout << "\n" << run.truth_md;
  const bool many = run.pairs.size() > 1;
  std::cout << "wrote " << a.out << (many ? "/<pair>/" : "/")
            << ": left_rect.png right_rect.png disparity16.png disparity.png depth_mm.png depth.png"
            << (a.ply ? " cloud.ply" : "") << "; depth.json" << (a.truth.empty() ? "" : " depth.csv depth.md") << "\n";
  if (run.failed) std::cerr << run.failed << " of " << run.pairs.size() << " ROI depth(s) refused (see depth.json)\n";
  return run.failed ? kExitFailed : kExitOk;
}

const bool kDepthRegistered = RegisterCommand(
    "depth",
    "Dense disparity and depth with a calibration (results.json, calibration.yaml or the course's\n"
    "intrinsics.xml + extrinsics.xml): rectify, StereoSGBM, write rectified images, disparity (16-bit and\n"
    "colour), depth (16-bit mm and colour), a PLY point cloud and the depth at a ROI with sigma (depth.json).\n"
    "Inputs: LEFT RIGHT images, one side-by-side frame, or a folder with --truth CSV\n"
    "(left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h]): then also depth.csv/.md with the error per pair,\n"
    "range-images' template ranging beside it, and the students' disp16 x distance = constant.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<pipeline::DepthRunOptions>();
      evaluation::SgbmOptions& s = o->depth.sgbm;
      cmd->add_option("inputs", o->inputs, "LEFT RIGHT, FRAME (side by side), or FOLDER with --truth")->required();
      cmd->add_option("--calib", o->calib, "calibration file or folder")->required();
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--truth", o->truth, "truth CSV (a folder of pairs at known distances)")
          ->check(CLI::ExistingFile);
      cmd->add_option("--truth-sigma-cm", o->truth_sigma_cm, "uncertainty of the true distances [cm]")
          ->capture_default_str();
      cmd->add_option("--roi", o->roi, "x y w h in the left rectified image (default: 64x48 at the centre)")
          ->expected(4);
      cmd->add_option("--min-disparity", s.min_disparity, "SGBM minDisparity [px]")->capture_default_str();
      cmd->add_option("--num-disparities", s.num_disparities, "SGBM numDisparities (multiple of 16)")
          ->capture_default_str();
      cmd->add_option("--block-size", s.block_size, "SGBM blockSize (odd)")->capture_default_str();
      cmd->add_option("--p1", s.p1, "SGBM P1 (0 = 8 blockSize^2)")->capture_default_str();
      cmd->add_option("--p2", s.p2, "SGBM P2 (0 = 32 blockSize^2)")->capture_default_str();
      cmd->add_option("--disp12-max-diff", s.disp12_max_diff, "SGBM left-right check [px], < 0 off")
          ->capture_default_str();
      cmd->add_option("--pre-filter-cap", s.pre_filter_cap, "SGBM preFilterCap")->capture_default_str();
      cmd->add_option("--uniqueness", s.uniqueness_ratio, "SGBM uniquenessRatio [%]")->capture_default_str();
      cmd->add_option("--speckle-window", s.speckle_window_size, "SGBM speckleWindowSize")->capture_default_str();
      cmd->add_option("--speckle-range", s.speckle_range, "SGBM speckleRange")->capture_default_str();
      cmd->add_option("--mode", s.mode, "SGBM mode: sgbm, hh, 3way, hh4")->capture_default_str();
      cmd->add_option("--alpha", o->depth.rectify_alpha, "stereoRectify alpha (-1 default, 0..1)")
          ->capture_default_str();
      cmd->add_option("--near-m", o->near_m, "colour scale of depth.png: nearest [m]")->capture_default_str();
      cmd->add_option("--far-m", o->far_m, "colour scale of depth.png: farthest [m]")->capture_default_str();
      cmd->add_option("--max-depth-m", o->depth.max_depth_m, "farthest point written to cloud.ply [m]")
          ->capture_default_str();
      cmd->add_flag("!--no-ply", o->ply, "do not write cloud.ply");
      cmd->add_flag("--mirror", o->mirror, "flip each image (or frame) horizontally first");
      cmd->add_flag("--swap", o->swap, "exchange the eyes");
      return [o] { return RunDepth(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
