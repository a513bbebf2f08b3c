#pragma once
// Target detection: an image -> the target's corners that are visible, with their stable ids.
//
// Pixels are in OpenCV's convention (docs/conventions.md, Pixels): (0,0) is the centre of the top-left
// pixel. AprilTags come from calib/apriltag_free.h (libapriltag's (0,0) at the top-left
// pixel's corner shifted by -0.5 px, docs/conventions.md, Facts). AprilTag corner ids follow calib/target.h:
// 4 * tag_id + k, k = 0 TL, 1 TR, 2 BR, 3 BL as seen on the upright board (target x right,
// y down), pinned by tests/calib/detector_test.cc on a rendered tag. A tag id seen more than
// once in one image is ambiguous for a grid: every copy is rejected and the message names it.
//
// Chessboard: classic = cv::findChessboardCorners + cv::cornerSubPix with a SMALL half-window
// (default 5, i.e. an 11x11 px window: OpenCV's stereo sample's 11 misplaces corners by up to
// 7 px on tilted boards); sb = cv::findChessboardCornersSB (no cornerSubPix); auto (the
// default, used by every command that reads image files) = classic, then sb. Both accept the
// board turned by 90 deg (rows x cols in the image) and order its corners on the target's own
// grid. sb returns classic's corners in reverse order (on every image of the repository's real
// sets where both find the board), so its list is reversed: whichever detector found a board,
// corner id k is the same physical corner. A failure's message lists every detector and size
// tried. fast_check (live video only:
// a frame without a board is rejected in a few ms) tries classic with CALIB_CB_FAST_CHECK
// alone, which gives up on low-contrast or blurred boards that the full search finds. Corner
// ids are row * cols + col in OpenCV's order; the whole board must be visible.
//
// Usage:
//   calib::DetectorOptions opt;  // classic, half-window 5
//   calib::TargetDetection d = calib::DetectTarget(gray, target, opt);
//   if (d.found) obs = calib::DetectionToObservations(d, target, frame_index, eye);
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/observation.h"
#include "calib/target.h"

namespace owlcal::calib {

enum class ChessboardMethod { kAuto, kClassic, kSectorBased };

// "auto", "classic" or "sb".
std::string ChessboardMethodName(ChessboardMethod method);

struct DetectorOptions {
  // chessboard
  ChessboardMethod chessboard_method = ChessboardMethod::kAuto;  // classic, then sb
  int subpix_half_window = 5;                                    // cornerSubPix winSize = (h, h): window (2h+1)^2 px
  int subpix_max_iterations = 100;
  double subpix_epsilon_px = 0.001;
  bool fast_check = false;         // live video: classic with CALIB_CB_FAST_CHECK only (see above)
  bool adaptive_threshold = true;  // CALIB_CB_ADAPTIVE_THRESH | NORMALIZE_IMAGE (classic)
  bool sb_accuracy = false;        // CALIB_CB_ACCURACY (sb)
  bool sb_exhaustive = false;      // CALIB_CB_EXHAUSTIVE (sb)
  // apriltag
  double apriltag_decimate = 2.0;    // quad_decimate
  double apriltag_blur_sigma = 0.0;  // quad_sigma
  bool apriltag_refine_edges = true;
  int apriltag_max_hamming = 1;     // bits corrected (<= 2)
  double apriltag_min_margin = 20;  // drop detections with a lower decision_margin
  int apriltag_min_tags = 1;        // fewer tags of the grid -> not found

  // False (and why names the field and value) if an option is out of range.
  bool Check(std::string* why) const;
};

struct TargetDetection {
  bool found = false;
  std::vector<int> corner_ids;          // ids of calib::TargetDefinition::Corners()
  std::vector<Eigen::Vector2d> pixels;  // OpenCV convention [px]
  std::string message;                  // why not found (what was tried) / what was dropped
  std::string detector;                 // chessboard found by: "classic 9x6", "sb 6x9", ...
};

// Detects `target` in an 8-bit grey or BGR image. Never throws for "not found"; throws
// std::invalid_argument for an empty image or a target kind it cannot detect (fixation).
TargetDetection DetectTarget(const cv::Mat& image, const TargetDefinition& target, const DetectorOptions& options);

// Several AprilGrids (distinct id ranges, e.g. tag sheets around a scene) in one image: the tag
// detector runs once per family, and each grid keeps its own tags (as DetectTarget would give
// them, one detection per grid in order). Throws std::invalid_argument for an empty image or a
// target that is not an aprilgrid.
std::vector<TargetDetection> DetectAprilGrids(const cv::Mat& image,
                                              const std::vector<TargetDefinition>& grids,
                                              const DetectorOptions& options);

// One CornerObservation per detected corner (point_in_target from target.Corners()).
std::vector<CornerObservation> DetectionToObservations(const TargetDetection& detection,
                                                       const TargetDefinition& target,
                                                       int frame_index,
                                                       int eye,
                                                       const models::PwmVector& pwm_us = {},
                                                       int64_t stamp_ns = 0);

// Splits a side-by-side stereo frame (e.g. 1280x480) into its halves. mirror: flip the whole
// frame horizontally first (the course's owl.h convention); swap: left eye = right half.
void SplitStereoFrame(const cv::Mat& frame, bool mirror, bool swap, cv::Mat* left, cv::Mat* right);

}  // namespace owlcal::calib
