#pragma once
// Template matching along the rectified row (issue 7, item 3): a template is cut from the
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
// unless given.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

namespace owlcal::calib {

struct StereoMatchOptions {
  cv::Rect template_roi;           // in the left rectified image; empty = central region
  int template_width = 64;         // size of the central region when template_roi is empty
  int template_height = 48;
  int min_disparity = 0;           // [px], x_left - x_right
  int max_disparity = 256;
  int row_search = 2;              // +- rows searched around the same row
  double min_ncc = 0.6;            // weaker peaks are "not found"
  double noise_sigma = 0;          // grey-level noise; 0 = estimate from the template
  double subpixel_floor_px = 0.1;

  bool Check(std::string* why) const;
};

struct StereoMatch {
  bool found = false;
  std::string message;             // why not found
  cv::Rect template_roi;           // as used (left rectified image)
  cv::Point2d left_px;             // template centre, left rectified image
  cv::Point2d right_px;            // matched centre, right rectified image (sub-pixel)
  double disparity_px = 0;         // left_px.x - right_px.x
  double dy_px = 0;                // right_px.y - left_px.y
  double ncc = 0;                  // peak score
  double second_ncc = 0;           // best score farther than 3 px from the peak (ambiguity)
  double sigma_disparity_px = 0;   // matching sigma (see above)
  double noise_sigma = 0;          // grey-level noise used
};

// left_rect, right_rect: rectified images of the same size, 8-bit grey or BGR (converted to
// grey). Throws std::invalid_argument for empty / mismatched images or options failing Check.
StereoMatch MatchAlongRow(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoMatchOptions& options);

// Sub-pixel offset of a peak from three samples (left, centre, right): in [-0.5, 0.5].
double ParabolaPeakOffset(double left, double centre, double right);

}  // namespace owlcal::calib
