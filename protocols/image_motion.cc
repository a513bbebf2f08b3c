#include "protocols/image_motion.h"

#include <algorithm>

#include <opencv2/imgproc.hpp>

namespace owlcal::protocols {

cv::Mat MotionThumb(const cv::Mat& eye_image, int downsample) {
  cv::Mat grey;
  if (eye_image.channels() == 3) {
    cv::cvtColor(eye_image, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = eye_image;
  }
  cv::Mat small;
  if (downsample > 1) {
    cv::resize(grey, small, cv::Size(grey.cols / downsample, grey.rows / downsample), 0, 0, cv::INTER_AREA);
  } else {
    small = grey;
  }
  cv::Mat f;
  small.convertTo(f, CV_64F);
  return f;
}

Shift ThumbShift(const cv::Mat& from_thumb, const cv::Mat& to_thumb, int downsample) {
  static thread_local cv::Mat window;
  if (window.size() != from_thumb.size()) cv::createHanningWindow(window, from_thumb.size(), CV_64F);
  Shift s;
  const cv::Point2d p = cv::phaseCorrelate(from_thumb, to_thumb, window, &s.response);
  s.px = Eigen::Vector2d(p.x, p.y) * downsample;
  return s;
}

double RimFraction(const cv::Mat& eye_image, int band_px, int dark_level) {
  cv::Mat grey;
  if (eye_image.channels() == 3) {
    cv::cvtColor(eye_image, grey, cv::COLOR_BGR2GRAY);
  } else {
    grey = eye_image;
  }
  const int w = grey.cols, h = grey.rows;
  int64_t dark = 0, total = 0;
  for (int y = 0; y < h; ++y) {
    const uint8_t* row = grey.ptr<uint8_t>(y);
    const bool edge_row = y < band_px || y >= h - band_px;
    for (int x = 0; x < w; ++x) {
      if (!edge_row && x >= band_px && x < w - band_px) {
        x = w - band_px - 1;
        continue;
      }
      ++total;
      if (row[x] < dark_level) ++dark;
    }
  }
  return total ? double(dark) / double(total) : 0.0;
}

}  // namespace owlcal::protocols
