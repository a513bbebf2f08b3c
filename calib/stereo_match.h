#pragma once
// Template matching along the rectified row: a template is cut from the
// LEFT rectified image (a given ROI, or a central region), and searched for in the RIGHT
// rectified image along the same rows by normalised cross-correlation
// (cv::matchTemplate, TM_CCOEFF_NORMED), over disparities d = x_left - x_right in
// [min_disparity, max_disparity] and, to absorb residual rectification error, vertical
// offsets in [-row_search, +row_search]. The peak is refined to sub-pixel by a parabola
// through it and its two neighbours, separately in x and y.
//
// Pixels: OpenCV's convention (centre of the top-left pixel is (0,0)); the template centre of
// a w x h ROI at (x, y) is (x + (w-1)/2, y + (h-1)/2).
//
// Matching sigma (disparity, px): the Cramer-Rao bound for a translation between two images
// with independent noise sigma_n, sigma_d^2 = 2 sigma_n^2 / sum (dI/dx)^2 over the template,
// combined in quadrature with `subpixel_floor_px` (parabola-fit bias, "pixel locking").
// sigma_n is estimated from the template by the median absolute Laplacian (Immerkaer 1996)
// unless given. The left-right check's disagreement adds in quadrature (half of it: each
// direction carries half the error).
//
// Confidence (a weak or ambiguous match is never a confident number): every check that fails
// is named in `flags`; the worst decides `confidence`:
//   failed          no peak, peak at the end of the disparity range, best NCC < min_ncc,
//                   template without texture (grey-level std < min_contrast, or matching sigma
//                   > max_sigma_disparity_fail_px), left-right check off by > lr_fail_px,
//                   second distinct NCC peak / best > peak_ratio_fail (repeated texture);
//   low_confidence  best NCC < low_ncc, matching sigma > max_sigma_disparity_low_px, left-right
//                   check off by > lr_tolerance_px, peak ratio > peak_ratio_low, the four
//                   quarters of the template matched alone disagree by more than
//                   max(block_tolerance_px, block_tolerance_fraction * disparity) (the template
//                   spans several depths: a target's edge against the background), |dy| at the
//                   edge of the row search (rectification off).
// Left-right check: the matched region of the right image is searched for in the left image
// along the same rows; it must land where the template came from. Second peak: the best NCC
// over rows, as a function of disparity, outside the main peak's lobe (down to its first
// minimum on each side), at a local maximum.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace owlcal::calib {

struct StereoMatchOptions {
  cv::Rect template_roi;    // in the left rectified image; empty = central region
  int template_width = 64;  // size of the central region when template_roi is empty
  int template_height = 48;
  int min_disparity = 0;  // [px], x_left - x_right
  int max_disparity = 256;
  int row_search = 2;      // +- rows searched around the same row
  double min_ncc = 0.6;    // weaker peaks are "not found"
  double noise_sigma = 0;  // grey-level noise; 0 = estimate from the template
  double subpixel_floor_px = 0.1;
  // Confidence checks (above).
  double low_ncc = 0.8;
  double min_contrast = 4.0;  // grey levels
  double max_sigma_disparity_low_px = 0.5;
  double max_sigma_disparity_fail_px = 2.0;
  double lr_tolerance_px = 1.0;
  double lr_fail_px = 3.0;
  double peak_ratio_low = 0.85;
  double peak_ratio_fail = 0.95;
  double block_tolerance_px = 1.5;
  double block_tolerance_fraction = 0.03;
  bool check_blocks = true;

  bool Check(std::string* why) const;
};

enum class MatchConfidence { kOk, kLowConfidence, kFailed };
// "ok", "low_confidence", "failed".
const char* ToString(MatchConfidence c);

struct StereoMatch {
  bool found = false;  // matched and no check failed (confidence ok or low_confidence)
  MatchConfidence confidence = MatchConfidence::kFailed;
  std::vector<std::string> flags;  // every check that failed, with its numbers
  std::string message;             // why not found, or the flags joined
  cv::Rect template_roi;           // as used (left rectified image)
  cv::Point2d left_px;             // template centre, left rectified image
  cv::Point2d right_px;            // matched centre, right rectified image (sub-pixel)
  double disparity_px = 0;         // left_px.x - right_px.x
  double dy_px = 0;                // right_px.y - left_px.y
  double ncc = 0;                  // peak score
  double second_ncc = 0;           // best distinct second peak (outside the main lobe), or -1
  double peak_ratio = 0;           // second_ncc / ncc (0 when no second peak)
  double lr_error_px = 0;          // left-right check disagreement (NaN when not done)
  double contrast = 0;             // grey-level std of the template
  double block_spread_px = 0;      // largest disagreement of a quarter with the whole
  int blocks_used = 0;
  double sigma_disparity_px = 0;  // matching sigma (see above)
  double noise_sigma = 0;         // grey-level noise used
};

// left_rect, right_rect: rectified images of the same size, 8-bit grey or BGR (converted to
// grey). Throws std::invalid_argument for empty / mismatched images or options failing Check.
StereoMatch MatchAlongRow(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoMatchOptions& options);

// Sub-pixel offset of a peak from three samples (left, centre, right): in [-0.5, 0.5].
double ParabolaPeakOffset(double left, double centre, double right);

}  // namespace owlcal::calib
