#pragma once
// Point clouds as PLY files (binary little-endian or ASCII, readable by MeshLab, CloudCompare,
// Open3D): one vertex per valid depth pixel, float x y z [m] in the LEFT RECTIFIED camera frame
// (evaluation/stereo_depth.h: x right, y down, z forward) and uchar red green blue from the
// rectified left image. The header's comments name the frame, unit and calibration source.
#include <string>

#include "evaluation/stereo_depth.h"

namespace owlcal::reports {

// Writes the cloud of `maps` (points with 0 < z <= max_depth_m); returns the number of points.
// Throws std::runtime_error naming the path if it cannot be written.
int WritePointCloudPly(const std::string& path,
                       const evaluation::DepthMaps& maps,
                       double max_depth_m,
                       const std::string& source,
                       bool binary = true);

}  // namespace owlcal::reports
