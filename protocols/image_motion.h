#pragma once
// Image motion between frames, for settle detection (the target stopped moving), limits
// validation (the image stopped moving when a servo hit its end-stop; the socket rim entered
// the image) and latency measurement (first image motion after a command).
//
// Shifts are measured by phase correlation (cv::phaseCorrelate with a Hanning window) on
// grey thumbnails downsampled by `downsample` (area averaging), and reported in FULL
// resolution pixels of one eye (x right, y down): shift = where content of `from` moved to
// in `to`.
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace owlcal::protocols {

// A grey float thumbnail of one eye image (8-bit BGR or grey in).
cv::Mat MotionThumb(const cv::Mat& eye_image, int downsample = 4);

struct Shift {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  // full-resolution pixels
  double response = 0;                           // phase-correlation peak (0..1): low = unreliable
};

// Shift between two thumbnails made with the same `downsample`.
Shift ThumbShift(const cv::Mat& from_thumb, const cv::Mat& to_thumb, int downsample);

// Fraction of the image border band (`band_px` wide, all four sides) darker than
// `dark_level` (0..255 grey): the eye socket rim intruding shows as a growing fraction.
double RimFraction(const cv::Mat& eye_image, int band_px = 8, int dark_level = 20);

}  // namespace owlcal::protocols
