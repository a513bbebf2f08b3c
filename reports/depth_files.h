#pragma once
// What `owlcal depth` writes (pipeline/depth.h runs it): per pair the rectified images, the
// disparity (16-bit and colour), the depth (16-bit mm and colour) and cloud.ply; depth.json; with
// a truth CSV depth.csv and depth.md (the error per pair, template ranging beside it, the
// students' "16-bit disparity x distance = constant").
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/stereo_depth.h"
#include "fitting/stereo_rig.h"

namespace owlcal::reports {

// Writes left_rect.png right_rect.png disparity16.png disparity.png depth_mm.png depth.png into
// `dir` (created) and, with `ply`, cloud.ply up to `max_depth_m`; returns the cloud's points.
// depth.png's colours span near_m..far_m.
int WriteDepthImages(const std::filesystem::path& dir,
                     const evaluation::DepthMaps& maps,
                     const evaluation::DepthOptions& options,
                     double near_m,
                     double far_m,
                     bool ply,
                     const std::string& source);

nlohmann::json DepthRoiJson(const evaluation::RoiDepth& d);
// A pair's entry in depth.json's "pairs".
nlohmann::json DepthPairJson(const evaluation::DepthPairResult& p);
// depth.json without its pairs: the calibration, the rectified geometry and the SGBM settings.
nlohmann::json DepthReportHeader(const fitting::StereoRig& rig,
                                 const fitting::Rectification& rect,
                                 const evaluation::DepthOptions& options);

// With a truth CSV: writes OUT/depth.csv and OUT/depth.md for `pairs` (a pair with a blank
// distance is listed and left out of the errors), adds "disparity_constant" to `report` and
// returns depth.md's text. `truth_sigma_cm`: the true distances' uncertainty.
std::string WriteDepthTruthTables(const std::string& out,
                                  const std::vector<evaluation::DepthPairResult>& pairs,
                                  const fitting::StereoRig& rig,
                                  const fitting::Rectification& rect,
                                  const evaluation::DepthOptions& options,
                                  double truth_sigma_cm,
                                  nlohmann::json* report);

}  // namespace owlcal::reports
