#pragma once
// `owlcal depth`'s workflow, the course's stereo_match exercise done with a calibration: load the
// pairs (LEFT RIGHT images, one side-by-side frame, or a folder of pairs named by a truth CSV),
// rectify them with the calibration, compute dense disparity and depth (evaluation/stereo_depth.h),
// write each pair's images (reports/depth_files.h), measure the depth at a ROI with its sigma and,
// at a known distance, range the same ROI as range-images does; then depth.json and, with a truth
// CSV, depth.csv and depth.md.
#include <functional>
#include <string>
#include <vector>

#include "evaluation/stereo_depth.h"
#include "fitting/stereo_rig.h"

namespace owlcal::pipeline {

struct DepthRunOptions {
  std::vector<std::string> inputs;    // LEFT RIGHT, one side-by-side frame, or a folder with `truth`
  std::string calib;                  // results.json, calibration.yaml, intrinsics.xml (+ extrinsics.xml) or a folder
  std::string truth;                  // truth CSV (evaluation/range_images_ranging.h ReadRangeTruthCsv); "" none
  std::string out;                    // output folder
  std::vector<int> roi;               // x y w h in the left rectified image; empty: 64 x 48 px at the centre
  bool mirror = false, swap = false;  // flip each image horizontally; exchange the eyes
  bool ply = true;                    // write cloud.ply
  double near_m = 0.2, far_m = 2.0;   // depth.png's colour scale [m]
  double truth_sigma_cm = 0;          // uncertainty of the true distances [cm]
  evaluation::DepthOptions depth;
  // False (and why) for a bad combination of inputs, a bad ROI or bad SGBM settings.
  bool Check(std::string* why) const;
};

struct DepthRun {
  fitting::StereoRig rig;
  fitting::Rectification rect;
  std::vector<evaluation::DepthPairResult> pairs;
  int failed = 0;        // pairs whose ROI depth was refused
  std::string truth_md;  // depth.md's text (with a truth CSV)
};

// Runs it and writes every file into options.out; `say` gets one line per pair as it is measured.
// Throws naming the file for an unreadable image, calibration or truth CSV.
DepthRun RunDepth(const DepthRunOptions& options, const std::function<void(const std::string&)>& say);

}  // namespace owlcal::pipeline
