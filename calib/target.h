#pragma once
// Calibration targets and their corner geometry.
//
// Target frame: origin at the first corner, x along the board's columns (to the right when
// the board is upright and faces the camera), y along its rows (down), z into the board, so a
// board facing the camera has its z axis pointing away from the camera. Units: metres.
//
// Chessboard: `cols` x `rows` INNER corners (OpenCV's patternSize = Size(cols, rows)), square
// side `square_m`. Corner id = row * cols + col at (col * square, row * square, 0): the order
// and coordinates of OpenCV's calibration samples.
//
// AprilGrid (Kalibr's convention for the parameters: tagCols, tagRows, tagSize, tagSpacing as a
// fraction of tagSize; family tag36h11): tag (col c, row r) has id first_id + r * tag_cols + c
// and its top-left black-border corner at (c * pitch, r * pitch, 0), pitch = size * (1 + spacing).
// Each tag contributes 4 corners with ids 4 * tag_id + k, k = 0 top-left, 1 top-right,
// 2 bottom-right, 3 bottom-left (as seen on the upright board, i.e. in target x/y). The
// detector (calib/) maps libapriltag's corner order onto these ids.
// Fixation target: a single point (a cross / disc), corner id 0 at the origin.
#include <map>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace owlcal::calib {

enum class TargetKind { kChessboard, kAprilGrid, kFixation };

struct TargetDefinition {
  std::string id = "board";
  TargetKind kind = TargetKind::kChessboard;
  // chessboard
  int cols = 9, rows = 6;
  double square_m = 0.026;
  // aprilgrid
  int tag_cols = 6, tag_rows = 6;
  double tag_size_m = 0.024;
  double tag_spacing = 0.3;
  int first_id = 0;
  std::string family = "tag36h11";
  // fixation target
  double fixation_radius_m = 0.01;

  // All corner ids and their positions in the target frame.
  std::map<int, Eigen::Vector3d> Corners() const;
  int NumCorners() const;
  // Outer extent of the printed pattern (for rendering): min/max x, y in the target frame.
  Eigen::Vector4d Extent() const;
};

}  // namespace owlcal::calib
