#include "calib/template_roi.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

#include "calib/apriltag_free.h"

namespace owlcal::calib {
namespace {

cv::Rect Clip(cv::Rect r, const cv::Size& s) { return r & cv::Rect(0, 0, s.width, s.height); }

// Grows r to at least w x h around its centre, inside the image.
cv::Rect AtLeast(const cv::Rect& r, int w, int h, const cv::Size& s) {
  const int nw = std::max(r.width, w), nh = std::max(r.height, h);
  cv::Rect g(r.x + r.width / 2 - nw / 2, r.y + r.height / 2 - nh / 2, nw, nh);
  g.x = std::clamp(g.x, 0, std::max(0, s.width - g.width));
  g.y = std::clamp(g.y, 0, std::max(0, s.height - g.height));
  return Clip(g, s);
}

TemplateRoiChoice Texture(const cv::Mat& grey, const TemplateRoiOptions& o) {
  TemplateRoiChoice c;
  cv::Mat gx, g2, integral;
  cv::Sobel(grey, gx, CV_64F, 1, 0, 3, 1.0 / 8.0);
  g2 = gx.mul(gx);
  cv::integral(g2, integral, CV_64F);
  const double cx = grey.cols / 2.0, cy = grey.rows / 2.0, s = o.centre_sigma_fraction * grey.cols;
  std::vector<std::pair<double, cv::Rect>> scored;
  for (int y = 0; y + o.height <= grey.rows; y += o.step_px) {
    for (int x = 0; x + o.width <= grey.cols; x += o.step_px) {
      const double sum = integral.at<double>(y + o.height, x + o.width) - integral.at<double>(y, x + o.width) -
                         integral.at<double>(y + o.height, x) + integral.at<double>(y, x);
      const double r2 = std::pow(x + o.width / 2.0 - cx, 2) + std::pow(y + o.height / 2.0 - cy, 2);
      scored.push_back({sum * std::exp(-r2 / (2 * s * s)), cv::Rect(x, y, o.width, o.height)});
    }
  }
  std::sort(scored.begin(), scored.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (const auto& [score, r] : scored) {
    if (static_cast<int>(c.candidates.size()) >= o.max_candidates) break;
    bool near = false;
    for (const auto& k : c.candidates) near |= std::abs(k.x - r.x) < o.width / 2 && std::abs(k.y - r.y) < o.height / 2;
    if (!near && score > 0) c.candidates.push_back(r);
  }
  c.how = c.candidates.empty() ? "no textured window near the centre"
                               : "most textured windows near the centre (" + std::to_string(c.candidates.size()) +
                                     " candidates, tried in order)";
  return c;
}

TemplateRoiChoice Colour(const cv::Mat& bgr, const TemplateRoiOptions& o) {
  TemplateRoiChoice c;
  if (bgr.channels() != 3) {
    c.how = "colour targets need a colour image";
    return c;
  }
  cv::Mat hsv, mask;
  cv::cvtColor(bgr, hsv, cv::COLOR_BGR2HSV);
  if (o.colour == "red") {
    cv::Mat a, b;
    cv::inRange(hsv, cv::Scalar(0, 70, 50), cv::Scalar(10, 255, 255), a);
    cv::inRange(hsv, cv::Scalar(168, 70, 50), cv::Scalar(180, 255, 255), b);
    mask = a | b;
  } else if (o.colour == "green") {
    cv::inRange(hsv, cv::Scalar(40, 80, 40), cv::Scalar(85, 255, 255), mask);
  } else if (o.colour == "blue") {
    cv::inRange(hsv, cv::Scalar(95, 80, 40), cv::Scalar(130, 255, 255), mask);
  } else {
    cv::inRange(hsv, cv::Scalar(20, 90, 80), cv::Scalar(35, 255, 255), mask);  // yellow
  }
  // Close gaps between letters: red text on a label becomes one blob per line.
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(15, 5)));
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids);
  const double cx = bgr.cols / 2.0, cy = bgr.rows / 2.0;
  double best = 0;
  cv::Rect pick;
  for (int i = 1; i < n; ++i) {
    const int area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < o.min_colour_area_px) continue;
    const double d = std::hypot(centroids.at<double>(i, 0) - cx, centroids.at<double>(i, 1) - cy);
    const double score = area / (1 + d / 100);
    if (score > best) {
      best = score;
      pick = cv::Rect(stats.at<int>(i, cv::CC_STAT_LEFT),
                      stats.at<int>(i, cv::CC_STAT_TOP),
                      stats.at<int>(i, cv::CC_STAT_WIDTH),
                      stats.at<int>(i, cv::CC_STAT_HEIGHT));
    }
  }
  if (best == 0) {
    c.how = "no " + o.colour + " blob of at least " + std::to_string(o.min_colour_area_px) + " px";
    return c;
  }
  const cv::Rect grown(pick.x - o.colour_margin_px,
                       pick.y - o.colour_margin_px,
                       pick.width + 2 * o.colour_margin_px,
                       pick.height + 2 * o.colour_margin_px);
  c.candidates.push_back(AtLeast(Clip(grown, bgr.size()), std::min(o.width, 32), std::min(o.height, 24), bgr.size()));
  c.how = "the " + o.colour + " blob nearest the centre (" + std::to_string(pick.width) + "x" +
          std::to_string(pick.height) + " px at " + std::to_string(pick.x) + "," + std::to_string(pick.y) + ")";
  return c;
}

TemplateRoiChoice Tag(const cv::Mat& img, const TemplateRoiOptions& o) {
  TemplateRoiChoice c;
  AprilTagOptions ao;
  ao.families = {o.tag_family};
  const auto tags = DetectAprilTags(img, ao);
  const double cx = img.cols / 2.0, cy = img.rows / 2.0;
  double best = 1e300;
  cv::Rect pick;
  int id = -1;
  for (const auto& t : tags) {
    if (o.tag_id >= 0 && t.id != o.tag_id) continue;
    const double d = std::hypot(t.centre.x() - cx, t.centre.y() - cy);
    if (d >= best) continue;
    best = d;
    id = t.id;
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (const auto& p : t.corners) {
      x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x());
      y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
    }
    const double m = 0.2 * std::max(x1 - x0, y1 - y0);
    pick = cv::Rect(cv::Point(static_cast<int>(x0 - m), static_cast<int>(y0 - m)),
                    cv::Point(static_cast<int>(x1 + m) + 1, static_cast<int>(y1 + m) + 1));
  }
  if (id < 0) {
    c.how = "no " + o.tag_family + " tag" + (o.tag_id >= 0 ? " with id " + std::to_string(o.tag_id) : std::string()) +
            " in the left image";
    return c;
  }
  c.candidates.push_back(AtLeast(Clip(pick, img.size()), 16, 16, img.size()));
  c.how = o.tag_family + " tag " + std::to_string(id);
  return c;
}

}  // namespace

bool TemplateRoiOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (mode != "texture" && mode != "colour" && mode != "tag")
    return fail("mode '" + mode + "': use texture, colour or tag");
  if (width < 8 || height < 8 || step_px < 1 || max_candidates < 1)
    return fail("template at least 8x8, step and candidates >= 1");
  if (!(centre_sigma_fraction > 0)) return fail("centre_sigma_fraction must be > 0");
  if (colour != "red" && colour != "green" && colour != "blue" && colour != "yellow")
    return fail("colour '" + colour + "': use red, green, blue or yellow");
  return true;
}

TemplateRoiChoice ChooseTemplateRois(const cv::Mat& img, const TemplateRoiOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("TemplateRoiOptions: " + why);
  if (img.empty()) throw std::invalid_argument("ChooseTemplateRois: empty image");
  if (o.mode == "colour") return Colour(img, o);
  cv::Mat grey = img;
  if (img.channels() == 3) cv::cvtColor(img, grey, cv::COLOR_BGR2GRAY);
  return o.mode == "tag" ? Tag(grey, o) : Texture(grey, o);
}

}  // namespace owlcal::calib
