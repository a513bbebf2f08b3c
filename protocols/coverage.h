#pragma once
// Image coverage of a set of board views, like ROS camera_calibration's X / Y / Size / Skew
// bars (image_pipeline camera_calibration/calibrator.py): for each view
//   border = sqrt(area of the board's outer-corner quadrilateral)
//   X = clamp((mean_x - border / 2) / (width - border), 0, 1), Y likewise with height,
//   Size = sqrt(area / (width * height)),
//   Skew = min(1, 2 |pi/2 - angle at the top-right outer corner|);
// and per parameter the progress = min(1, (max - min) / range) with ranges X 0.7, Y 0.7,
// Size 0.4, Skew 0.5 (ROS's thresholds). A set is "good" when every progress reaches 1.
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "calib/target.h"

namespace owlcal::protocols {

struct ViewParams {
  double x = 0, y = 0, size = 0, skew = 0;
};

struct Coverage {
  int num_views = 0;
  double min[4] = {0, 0, 0, 0}, max[4] = {0, 0, 0, 0};  // X, Y, Size, Skew
  double progress[4] = {0, 0, 0, 0};
  bool Good() const { return progress[0] >= 1 && progress[1] >= 1 && progress[2] >= 1 && progress[3] >= 1; }
  // "X [####------] 0.45 ..." one line per parameter.
  std::string Bars() const;
};

// Parameters of one view from its detected corners (ids of target.Corners()); nullopt-like
// false when the four outer corners of the board are not all detected (chessboards) or
// fewer than 4 corners exist.
bool ComputeViewParams(
    const calib::View& view, const calib::TargetDefinition& target, int width, int height, ViewParams* params);

Coverage ComputeCoverage(const std::vector<ViewParams>& views);

}  // namespace owlcal::protocols
