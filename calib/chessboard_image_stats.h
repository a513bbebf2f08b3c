#pragma once
// Photometric statistics of one image of a detected chessboard: what a real camera does to the
// picture (noise, blur, exposure, lens shading, JPEG blocks), measured the same way on real
// Owl images and on the virtual Owl's, so the two can be put side by side
// (fitting/capture_stats.h).
//
// All measurements use the detected inner corners (OpenCV pixel convention, docs/conventions.md, Pixels):
//   - squares: the quadrilateral of four neighbouring corners; its interior (bilinear
//     coordinates s, t in [0.25, 0.75]) is sampled pixel by pixel. A square is white or
//     black by its mean against the board's median.
//   - noise_*: standard deviation of the interior pixels about a plane fitted to them (so
//     illumination gradients do not count), 3-sigma clipped; the median over the squares of one
//     colour (so printed marks on a few squares do not count) [grey levels]. JPEG smoothing is
//     part of what is measured.
//   - edge_sigma_px: the Gaussian blur sigma of the board's edges. Along each edge between two
//     neighbouring corners (s in [0.3, 0.7], away from the X-junctions) the profile across
//     the edge is averaged and fitted by m + a * erf((d - d0) / (sqrt(2) sigma)); median over
//     edges. A perfectly sharp edge sampled by square pixels gives about 0.35 px.
//   - white_level / black_level: medians of the square interiors; saturated_fraction: share of
//     interior pixels at 255 or 0.
//   - shading: per white square, (normalised radius^2 of its centre, its mean grey); the
//     caller fits the brightness fall-off over many images.
//   - blockiness (JpegBlockiness): mean |difference| across the 8x8 JPEG block boundaries over
//     the mean |difference| between other neighbouring pixels (1 = no block artefacts).
//
// Usage:
//   calib::TargetDetection d = calib::DetectTarget(grey, board, {});
//   calib::ChessboardImageStats s = calib::MeasureChessboardImage(grey, d, board);
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/detector.h"
#include "calib/target.h"

namespace owlcal::calib {

struct ChessboardImageStats {
  bool ok = false;
  std::string message;                      // why not ok
  double white_level = 0, black_level = 0;  // grey levels 0..255
  double noise_white = 0, noise_black = 0;  // grey levels
  double edge_sigma_px = 0;
  int num_edges = 0;
  double saturated_fraction = 0;
  double board_area_fraction = 0;  // area of the corners' convex hull / image area
  // Per white square: its centre from the image centre over the centre-to-corner distance
  // (x right, y down), and its mean grey.
  struct ShadingSample {
    double x = 0, y = 0, grey = 0;
  };
  std::vector<ShadingSample> shading;
};

// Needs a chessboard detection with every inner corner (classic or SB detector). `image` may
// be grey or BGR (converted with cv::COLOR_BGR2GRAY, as the detector does).
ChessboardImageStats MeasureChessboardImage(const cv::Mat& image,
                                            const TargetDetection& detection,
                                            const TargetDefinition& target);

// Block artefact ratio of an 8-bit image (grey or BGR): see the header comment.
double JpegBlockiness(const cv::Mat& image);

// The IJG quality (1..100) whose luminance table best matches the first quantisation table of
// a JPEG file's bytes; -1 when the bytes hold no DQT segment.
int JpegQualityEstimate(const std::vector<unsigned char>& jpeg_bytes);

}  // namespace owlcal::calib
