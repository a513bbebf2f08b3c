#pragma once
// Choosing what to range in a left rectified image (calib/stereo_match.h's template), besides a
// given ROI:
//   texture  the most textured windows near the image centre: score = sum of squared
//            horizontal gradients in the window (the disparity information, the inverse of the
//            matching variance) x exp(-r^2 / (2 s^2)), r the window centre's distance from the
//            image centre, s = `centre_sigma_fraction` x image width; windows on a grid of
//            `step_px`, the best `max_candidates` at least half a window apart. The ranging
//            tries them in order and keeps the first whose match is confident, so a window
//            astride a depth edge or on repeated texture gives way to the next.
//   colour   the blob of a named colour (red, green, blue, yellow: HSV ranges; gaps up to 15 x 5
//            px closed, so a line of coloured text is one blob) with the largest area / (1 +
//            distance from the centre / 100 px), its bounding box grown by `colour_margin_px` (a
//            colour blob's own inside is often flat; its edges carry the texture), at least
//            32 x 24 px.
//   tag      an AprilTag (calib/apriltag_free.h; `tag_id` < 0: any, the one nearest the
//            centre), its bounding box grown by a fifth of its size.
// Not found (no such colour or tag) -> empty candidates and a message.
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace owlcal::calib {

struct TemplateRoiOptions {
  std::string mode = "texture";  // texture, colour, tag
  int width = 64, height = 48;   // template size (texture; the least for colour and tag)
  int step_px = 8;
  double centre_sigma_fraction = 0.2;
  int max_candidates = 6;
  std::string colour = "red";
  int colour_margin_px = 6;
  int min_colour_area_px = 30;
  std::string tag_family = "tag36h11";
  int tag_id = -1;
  bool Check(std::string* why) const;
};

struct TemplateRoiChoice {
  std::vector<cv::Rect> candidates;  // best first
  std::string how;                   // what was chosen and why, or why nothing was
};

// image: 8-bit grey or BGR (colour mode needs BGR). Throws std::invalid_argument for options
// failing Check or an empty image.
TemplateRoiChoice ChooseTemplateRois(const cv::Mat& left_rect, const TemplateRoiOptions& options);

}  // namespace owlcal::calib
