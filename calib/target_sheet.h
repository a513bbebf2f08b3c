#pragma once
// Printable calibration targets: a chessboard or AprilGrid laid out at true scale on a page,
// with its dimensions, printing instructions and a scale-check bar, written as PDF or SVG.
//
// Page frame: millimetres, origin at the page's top-left corner, x right, y down (SVG's user
// units with viewBox = page size in mm; the PDF writer flips y and scales to points,
// 72 / 25.4 pt per mm). The target frame (calib/target.h) is placed upright, unrotated, with
// its origin (corner 0) at `target_origin_mm`, so target point (x, y) [m] lies on the page at
// target_origin_mm + 1000 (x, y).
//
// Patterns, exactly as the detector and the virtual Owl's renderer expect them:
//   chessboard: (cols + 1) x (rows + 1) squares; the square whose bottom-right corner is inner
//     corner 0 is black (as sim/renderer.cc draws it).
//   AprilGrid: tag36h11 bitmaps from libapriltag (8 x 8 bits border to border, tagSize is the
//     black border's outer width), gaps tagSpacing * tagSize. Kalibr's own AprilGrid also puts
//     small black squares in the gaps for its detector; owlcal's detector (libapriltag) does not
//     use them, so they are not drawn.
// Black areas are one filled path (nonzero rule), so rasterisers draw no seams between bits.
//
// Usage:
//   calib::TargetSheetOptions o;  // paper "auto": the smallest ISO A size that fits
//   calib::TargetSheet s = calib::LayoutTargetSheet(target, o);   // throws if it cannot fit
//   WriteStringFile("board.pdf", calib::TargetSheetPdf(s));
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/target.h"

namespace owlcal::calib {

struct TargetSheetOptions {
  // "auto" (smallest of A4, A3, A2, A1, A0 that fits, either orientation), "A4".."A0",
  // "letter", "legal", or "WxH" in millimetres (e.g. "300x300").
  std::string paper = "auto";
  double printer_margin_mm = 8;  // kept free at every page edge
  double scale_bar_mm = 100;     // length of the scale-check bar (shortened to fit if needed)
  std::string note;              // an extra line under the title (e.g. the target file's name)

  bool Check(std::string* why) const;
};

struct SheetRect {
  double x_mm, y_mm, w_mm, h_mm;  // top-left corner and size, page frame
};
struct SheetText {
  double x_mm, y_mm;  // baseline start, page frame
  double size_mm;     // font size (cap height is about 0.7 of it)
  std::string text;   // printable ASCII
};

struct TargetSheet {
  std::string paper_name;  // "A3 landscape", "300 x 300 mm"
  double width_mm = 0, height_mm = 0;
  std::vector<SheetRect> black;  // the pattern, the scale bar and its ticks
  std::vector<SheetText> texts;
  Eigen::Vector2d target_origin_mm = Eigen::Vector2d::Zero();  // target frame origin on the page
  SheetRect pattern_mm{};    // the printed pattern's extent (TargetDefinition::Extent())
  SheetRect scale_bar_mm{};  // the solid scale bar
  double scale_bar_length_mm = 0;
};

// Lays the target out. Throws std::invalid_argument naming the target, the paper and the sizes
// when the pattern and its annotations do not fit, for a fixation target, a non-positive size,
// a family other than tag36h11 or tag ids outside it.
TargetSheet LayoutTargetSheet(const TargetDefinition& target, const TargetSheetOptions& options);

// The sheet as an SVG document (width/height in mm, viewBox in mm).
std::string TargetSheetSvg(const TargetSheet& sheet);
// The sheet as a one-page PDF 1.4 document (Helvetica, no embedded fonts).
std::string TargetSheetPdf(const TargetSheet& sheet);

// Human-readable dimensions of a target, e.g. "chessboard 9 x 6 inner corners (10 x 7
// squares), square 26.00 mm, pattern 260.0 x 182.0 mm".
std::string DescribeTargetDimensions(const TargetDefinition& target);

}  // namespace owlcal::calib
