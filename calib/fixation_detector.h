#pragma once
// Single fixation targets: the centre of a disc (or any compact, point-symmetric blob such as
// a bullseye or a thick cross) with sub-pixel accuracy, and template matching by normalised
// correlation as in the course's Owl-1 demo (a template cut from one eye is found in the
// other).
//
// Pixels in OpenCV's convention (docs/conventions.md, Pixels): (0,0) is the centre of the top-left
// pixel.
//
// Disc: the image is thresholded (Otsu, or the given polarity), connected blobs are scored by
// roundness (4 pi area / perimeter^2, and area / enclosing-circle area), squared contrast,
// the uniformity of its surround (a disc on a plain card beats textured dark spots) and size;
// the best blob's centre is the intensity-weighted centroid of its contrast against the local
// background (a ring around it), which is unbiased for a symmetric antialiased disc.
//
// Template: cv::matchTemplate with TM_CCOEFF_NORMED; the peak is refined by a parabola fit in
// x and y (sub-pixel). The returned centre is where the template's centre lies.
//
// Usage:
//   calib::FixationDetection d = calib::DetectFixationTarget(left, {});
//   if (d.found) error_px = d.centre - Eigen::Vector2d(319.5, 239.5);
#include <string>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace owlcal::calib {

struct FixationDetectorOptions {
  bool dark_on_light = true;  // a dark disc on a lighter surround (false: light on dark)
  double min_radius_px = 3;   // blobs smaller/larger than this are ignored
  double max_radius_px = 150;
  // > 0: the disc's expected radius [px], from its known size, its placed distance and a nominal
  // focal length. Blobs outside 0.5x..2x of it are ignored instead of those outside
  // min/max_radius_px (a 24 mm disc at 2 m is 2.9 px on a 480 px lens, below the default
  // minimum, and a 12 px dark spot of the wall must not stand in for it). At least 1 px.
  double size_hint_px = 0;
  double min_roundness = 0.6;  // 0..1, see above
  double min_contrast = 25;    // grey levels between the blob and its surround
  int border_px = 2;           // blobs touching the image border closer than this are ignored
  // Tracking: when expected_radius_px > 0, only blobs of 0.5x..2x that radius are kept and
  // the one closest to expected_px wins (instead of the best score).
  Eigen::Vector2d expected_px = Eigen::Vector2d::Zero();
  double expected_radius_px = 0;

  bool Check(std::string* why) const;
};

struct FixationDetection {
  bool found = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // [px]
  double radius_px = 0;                              // equivalent radius sqrt(area / pi)
  double roundness = 0;
  double contrast = 0;  // grey levels
  std::string message;  // why not found
};

// Finds the best fixation blob in an 8-bit grey or BGR image. Never throws for "not found";
// throws std::invalid_argument for an empty image.
FixationDetection DetectFixationTarget(const cv::Mat& image, const FixationDetectorOptions& options);

struct TemplateMatch {
  bool found = false;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // template centre in the image [px]
  double score = 0;                                  // normalised correlation at the peak (-1..1)
};

// Cuts a (2 * half_size + 1)^2 grey template centred on pixel `centre` (rounded). Throws
// std::invalid_argument if it does not fit in the image.
cv::Mat CutTemplate(const cv::Mat& image, const Eigen::Vector2d& centre, int half_size);

// Finds `templ` (grey, odd size) in `image` by normalised correlation; found when the peak
// score is >= min_score. search (optional) restricts the template centre's search area.
TemplateMatch MatchTemplateNcc(const cv::Mat& image,
                               const cv::Mat& templ,
                               double min_score = 0.6,
                               const cv::Rect& search = cv::Rect());

}  // namespace owlcal::calib
