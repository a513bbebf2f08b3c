#pragma once
// Free-standing AprilTags: every tag of the requested families in an arbitrary image, with
// its id, family, corners and decision margin (libapriltag 3.3, Debian's libapriltag3).
//
// Families: every family libapriltag 3.3 ships (AprilTagFamilyNames()): tag36h11, tag36h10,
// tag25h9, tag16h5, tagCircle21h7, tagCircle49h12, tagCustom48h12, tagStandard41h12,
// tagStandard52h13.
//
// Pixels: OpenCV's convention (docs/conventions.md, Pixels, (0,0) is the centre of the top-left
// pixel). libapriltag puts (0,0) at the top-left pixel's CORNER, so its corners and centre are
// shifted by -0.5 px in x and y here (docs/conventions.md, Facts), pinned by
// tests/calib/apriltag_free_test.cc on rendered tags with known corners and against the library
// called directly.
//
// Corner refinement (refine_corners, on by default): libapriltag's refine_edges leaves corners
// up to 0.3 px off when a tag's edges run along the pixel grid (measured on area-sampled
// renders: 0.27-0.40 px at 0 deg, < 0.1 px at 17 deg). owlcal then fits each of the quad's four
// edges again: along the middle 80 % of the edge, every 0.5 px, the grey-level profile across
// the edge (bilinear, +-0.45 cell) gives the sub-pixel point where it crosses half-way between
// its two sides (unbiased for an area-sampled or symmetrically blurred straight step, whatever
// its orientation); a line through those points (total least squares, one 3-sigma rejection
// pass) per edge, and the corners are the intersections of adjacent lines. Samples with too
// little contrast (another cell of the same colour beside the edge, glare) are skipped; an
// edge with fewer than 6 usable samples keeps the library's corners for that tag
// (`corners_refined` false). `library_corners` always holds libapriltag's own corners (-0.5 px).
// Corner order: 0 top-left, 1 top-right, 2 bottom-right, 3 bottom-left of the upright tag as
// apriltag_to_image() draws it (image x right, y down); the library's own order is
// bottom-left, bottom-right, top-right, top-left, i.e. corners[k] = p[3 - k]. The corners are
// those of the quad the library detects: the outer edge of the black border for the classic
// families (cells 1 .. total_width - 1), the `width_at_border` square for the others
// (AprilTagQuadCells()).
//
// Repeated ids: free-standing detection keeps EVERY detection, a repeated (family, id) too,
// and marks each of them `repeated_id = true` with `id_count` (how often the id occurs in the
// image); the caller decides. (A grid target, calib/detector.h, rejects all copies of a
// repeated id instead, because a grid id names one physical corner.)
// Order of the result, deterministic for a given image and options: by family name, id, then
// the centre's y and x.
//
// Usage:
//   calib::AprilTagOptions o;                  // tag36h11, decimate 2, refine_edges on
//   o.families = {"tag36h11", "tag25h9"};
//   for (const calib::AprilTagDetection& t : calib::DetectAprilTags(grey, o)) ...
#include <array>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace owlcal::calib {

struct AprilTagOptions {
  std::vector<std::string> families = {"tag36h11"};  // or {"all"}
  double quad_decimate = 2.0;                        // libapriltag quad_decimate: 1 = full resolution (slower, ~3x)
  double quad_sigma = 0.0;                           // Gaussian blur before quad detection [px]
  bool refine_edges = true;  // off: corners about 0.85 px off instead of 0.15 (docs/conventions.md)
  double decode_sharpening = 0.25;
  int max_hamming = 1;             // bits corrected: 0..2 (2 only for families up to 10000 codes)
  double min_decision_margin = 0;  // drop weaker detections (0 keeps all; the margin is reported)
  bool refine_corners = true;      // owlcal's edge fit after libapriltag (see above)

  bool Check(std::string* why) const;
};

struct AprilTagDetection {
  std::string family;
  int id = 0;
  int hamming = 0;                                   // bits corrected
  double decision_margin = 0;                        // libapriltag's decision_margin
  std::array<Eigen::Vector2d, 4> corners;            // OpenCV convention, order above
  std::array<Eigen::Vector2d, 4> library_corners;    // libapriltag's corners - 0.5 px, same order
  bool corners_refined = false;                      // corners come from owlcal's edge fit
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // OpenCV convention
  bool repeated_id = false;                          // another detection in this image has the same family and id
  int id_count = 1;                                  // detections of this (family, id) in the image
};

// Names of the families libapriltag 3.3 ships.
std::vector<std::string> AprilTagFamilyNames();

// Cell coordinates (apriltag_to_image's cells, cell i spans [i, i+1]) of the detected quad's
// top-left and bottom-right corner: border b = (total_width - width_at_border) / 2, so the
// quad spans [b, b + width_at_border]. Throws std::invalid_argument for an unknown family.
void AprilTagQuadCells(const std::string& family, double* first_cell, double* last_cell, int* total_width);

// All tags of options.families in an 8-bit grey or BGR image. Throws std::invalid_argument for
// an empty image or options failing Check (naming the field).
std::vector<AprilTagDetection> DetectAprilTags(const cv::Mat& image, const AprilTagOptions& options);

}  // namespace owlcal::calib
