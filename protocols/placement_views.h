#pragma once
// Views of a recorded dataset with one board identity per placement.
//
// A protocol may place the SAME target (one target_id, e.g. "chessboard") at several poses
// (servo_sweep: 0.6 m, then 0.85 m turned). Fits that estimate one fixed base_from_target per
// target_id (fitting::FitHead) must see each placement as its own board, else they force two
// poses into one and land in a wrong minimum. SplitViewsByPlacement renames the target of
// every view whose target was seen under more than one placement to
// "<target_id>@placement<N>" (N = frames.csv placement_index); targets seen under one
// placement keep their id.
//
// Usage:
//   std::vector<calib::View> views = protocols::ReadViewsByPlacement(dataset_dir);
//   fitting::FitHead(views, robot, initial, options);
#include <string>
#include <vector>

#include "calib/observation.h"
#include "protocols/dataset.h"

namespace owlcal::protocols {

// `frames`: the dataset's frames.csv records (frame_index -> placement_index). Views whose
// frame is not listed keep their id. With `placements` (placements.csv), a view's placement is
// the latest placement OF ITS TARGET at or before its frame's: a target the protocol never
// moves (a tag grid fixed in the scene, protocol `tag_targets`) stays one board while other
// targets are placed around it; N is then that placement's index (the same names as without
// `placements` for a target placed at every placement).
std::vector<calib::View> SplitViewsByPlacement(std::vector<calib::View> views,
                                               const std::vector<FrameRecord>& frames,
                                               const std::vector<PlacementRecord>* placements = nullptr);

// observations.csv grouped into views (calib::GroupIntoViews), split by frames.csv's
// placements. Empty when the dataset has no observations.csv. Throws std::runtime_error
// naming the path when a file cannot be read.
std::vector<calib::View> ReadViewsByPlacement(const std::string& dataset_dir);

}  // namespace owlcal::protocols
