#pragma once
// Image sharpness in a region of any scene: how much the camera blurs a step edge, and the
// variance of the Laplacian (the usual autofocus figure, as in the course notes' "image
// sharpness can be estimated ... a predominance of low frequency edges indicates blur").
//
// Edge blur (the primary measure; it does not depend on what the region shows, only on
// edges being there):
//   - Gradient by the 3x3 Sobel operator; candidate edge points are the local maxima of the
//     gradient magnitude along the gradient direction (non-maximum suppression, as Canny),
//     at least `min_gradient_fraction` of the region's 99th-percentile gradient.
//   - Each point's edge centre is refined along the gradient direction n by a parabola
//     through the magnitude at -1, 0, +1 px.
//   - The edge spread function is read from the pixels themselves (no interpolation, which
//     would add its own blur): every pixel within `probe_px` of the centre along n and 1.5 px
//     across, at its signed distance d along n. It is fitted by least squares with
//     I(d) = m + (C / 2) erf((d - d0) / (sqrt(2) s)): s is the Gaussian-equivalent blur of
//     the whole imaging chain (lens, defocus, demosaicing, JPEG; a perfectly sharp edge on
//     square pixels gives sqrt(1/12) = 0.29 px).
//   - Kept when the step C is at least `min_step` grey levels, the fit explains the profile
//     (RMS <= `max_fit_rms_fraction` * C: an isolated straight step, not a corner, a line or
//     texture), |d0| <= 1 px and s <= probe_px / 1.5 (both plateaus inside the window).
//   - The result is the median of s over the kept points, with its spread (IQR) and the
//     standard error of the median (points closer than the window are not independent:
//     one in three counts).
// Laplacian variance: var(Laplacian(I)) / C^2 over the region, C = the 95th minus the 5th
// percentile grey level (normalised so exposure and contrast do not count). It grows with
// sharpness but also with how much texture the region holds, so compare it only across
// images of the same target at the same scale.
//
// Usage:
//   calib::EdgeSharpness s = calib::MeasureEdgeSharpness(grey, cv::Rect(280, 200, 80, 80));
//   if (s.ok) std::cout << s.blur_sigma_px << " +- " << s.blur_sigma_se_px << " px\n";
#include <string>

#include <opencv2/core.hpp>

namespace owlcal::calib {

struct EdgeSharpnessOptions {
  double probe_px = 4.0;               // half-width of the profile window along the gradient [px]
  double min_step = 30;                // grey levels between the two sides of a kept edge
  double max_fit_rms_fraction = 0.08;  // of the step: the erf must explain the profile
  double min_gradient_fraction = 0.3;  // of the region's 99th-percentile gradient magnitude
  int min_edges = 12;                  // fewer kept edge points: not ok
  bool Check(std::string* why) const;
};

struct EdgeSharpness {
  bool ok = false;
  std::string reason;             // why not ok ("" when ok)
  cv::Rect roi;                   // the region measured (clipped to the image)
  int num_candidates = 0;         // edge maxima looked at
  int num_edges = 0;              // edge points kept
  double blur_sigma_px = 0;       // median Gaussian-equivalent edge blur [px]
  double blur_sigma_iqr_px = 0;   // interquartile range over the kept points [px]
  double blur_sigma_se_px = 0;    // standard error of the median [px]
  double laplacian_variance = 0;  // var(Laplacian) / contrast^2
  double contrast = 0;            // 95th - 5th percentile grey level in the region
};

// `image`: 8-bit grey or BGR (converted to grey). `roi` is clipped to the image; an empty or
// too small region, or too few edges, gives ok = false with the reason.
EdgeSharpness MeasureEdgeSharpness(const cv::Mat& image, const cv::Rect& roi, const EdgeSharpnessOptions& options = {});

}  // namespace owlcal::calib
