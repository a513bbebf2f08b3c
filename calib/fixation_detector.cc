#include "calib/fixation_detector.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

cv::Mat Grey(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("fixation detector: empty image");
  cv::Mat g;
  if (image.channels() == 3) {
    cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, g, cv::COLOR_BGRA2GRAY);
  } else {
    g = image;
  }
  if (g.type() != CV_8U) g.convertTo(g, CV_8U);
  return g;
}

// Median grey level of the ring r_in..r_out around c (clipped to the image); *sd (optional)
// the ring's standard deviation.
double RingMedian(const cv::Mat& g, const cv::Point2d& c, double r_in, double r_out, double* sd = nullptr) {
  std::vector<uint8_t> v;
  const int x0 = std::max(0, int(c.x - r_out)), x1 = std::min(g.cols - 1, int(c.x + r_out) + 1);
  const int y0 = std::max(0, int(c.y - r_out)), y1 = std::min(g.rows - 1, int(c.y + r_out) + 1);
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double d = std::hypot(x - c.x, y - c.y);
      if (d >= r_in && d <= r_out) v.push_back(g.at<uint8_t>(y, x));
    }
  if (v.empty()) return 0;
  if (sd) {
    double m = 0, m2 = 0;
    for (uint8_t x : v) {
      m += x;
      m2 += double(x) * x;
    }
    m /= v.size();
    *sd = std::sqrt(std::max(0.0, m2 / v.size() - m * m));
  }
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

}  // namespace

bool FixationDetectorOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(min_radius_px > 0)) return fail("min_radius_px " + std::to_string(min_radius_px) + " must be > 0");
  if (!(max_radius_px > min_radius_px))
    return fail("max_radius_px " + std::to_string(max_radius_px) + " must exceed min_radius_px");
  if (!(min_roundness >= 0 && min_roundness <= 1))
    return fail("min_roundness " + std::to_string(min_roundness) + " must be in [0, 1]");
  if (!(size_hint_px >= 0) || !std::isfinite(size_hint_px))
    return fail("size_hint_px " + std::to_string(size_hint_px) + " must be >= 0 and finite");
  if (border_px < 0) return fail("border_px " + std::to_string(border_px) + " must be >= 0");
  return true;
}

FixationDetection DetectFixationTarget(const cv::Mat& image, const FixationDetectorOptions& options) {
  const cv::Mat g = Grey(image);
  FixationDetection best;
  best.message = "no round blob of the expected size and contrast";
  cv::Mat bin;
  cv::threshold(g, bin, 0, 255, (options.dark_on_light ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY) | cv::THRESH_OTSU);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(bin, contours, cv::RETR_LIST, cv::CHAIN_APPROX_NONE);
  double best_score = -1;
  const double min_r = options.size_hint_px > 0 ? std::max(1.0, 0.5 * options.size_hint_px) : options.min_radius_px;
  const double max_r = options.size_hint_px > 0 ? std::max(2.0, 2 * options.size_hint_px) : options.max_radius_px;
  const double min_area = M_PI * min_r * min_r;
  const double max_area = M_PI * max_r * max_r;
  for (const auto& c : contours) {
    const double area = cv::contourArea(c);
    if (area < min_area || area > max_area) continue;
    const cv::Rect box = cv::boundingRect(c);
    if (box.x < options.border_px || box.y < options.border_px || box.x + box.width > g.cols - options.border_px ||
        box.y + box.height > g.rows - options.border_px)
      continue;
    const double perimeter = cv::arcLength(c, true);
    cv::Point2f cc;
    float cr = 0;
    cv::minEnclosingCircle(c, cc, cr);
    const double circ = perimeter > 0 ? 4 * M_PI * area / (perimeter * perimeter) : 0;
    const double fill = cr > 0 ? area / (M_PI * cr * cr) : 0;
    const double roundness = std::min(1.0, std::sqrt(std::min(1.0, circ) * fill));
    if (roundness < options.min_roundness) continue;
    const double r = std::sqrt(area / M_PI);
    const bool tracking = options.expected_radius_px > 0;
    if (tracking && (r < 0.5 * options.expected_radius_px || r > 2 * options.expected_radius_px)) continue;
    const cv::Point2d centre0(cc.x, cc.y);
    double ring_sd = 0;
    const double bg = RingMedian(g, centre0, cr * 1.3 + 1, cr * 1.6 + 3, &ring_sd);
    const double fg = RingMedian(g, centre0, 0, std::max(1.0, cr * 0.5));
    const double contrast = options.dark_on_light ? bg - fg : fg - bg;
    if (contrast < options.min_contrast) continue;
    // A fixation target is a disc on a plain card: high contrast against a uniform surround
    // wins over dark spots of a textured background.
    const double uniformity = 1.0 / (1.0 + 4.0 * ring_sd / contrast);
    const double score = tracking
                             ? 1.0 / (1.0 + std::hypot(cc.x - options.expected_px.x(), cc.y - options.expected_px.y()))
                             : roundness * contrast * contrast * uniformity * std::sqrt(r);
    if (score <= best_score) continue;
    // Sub-pixel centre: contrast-weighted centroid inside 1.25 * the enclosing radius.
    const double rw = cr * 1.25 + 1;
    double sw = 0, sx = 0, sy = 0;
    const int x0 = std::max(0, int(cc.x - rw)), x1 = std::min(g.cols - 1, int(cc.x + rw) + 1);
    const int y0 = std::max(0, int(cc.y - rw)), y1 = std::min(g.rows - 1, int(cc.y + rw) + 1);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        if (std::hypot(x - cc.x, y - cc.y) > rw) continue;
        const double v = g.at<uint8_t>(y, x);
        const double w = std::clamp(options.dark_on_light ? bg - v : v - bg, 0.0, contrast);
        sw += w;
        sx += w * x;
        sy += w * y;
      }
    if (sw <= 0) continue;
    best_score = score;
    best.found = true;
    best.centre = Eigen::Vector2d(sx / sw, sy / sw);
    best.radius_px = r;
    best.roundness = roundness;
    best.contrast = contrast;
    best.message.clear();
  }
  return best;
}

cv::Mat CutTemplate(const cv::Mat& image, const Eigen::Vector2d& centre, int half_size) {
  const cv::Mat g = Grey(image);
  const int cx = static_cast<int>(std::lround(centre.x())), cy = static_cast<int>(std::lround(centre.y()));
  const cv::Rect r(cx - half_size, cy - half_size, 2 * half_size + 1, 2 * half_size + 1);
  if (half_size < 1 || r.x < 0 || r.y < 0 || r.x + r.width > g.cols || r.y + r.height > g.rows)
    throw std::invalid_argument("CutTemplate: a " + std::to_string(r.width) + " px template at (" + std::to_string(cx) +
                                ", " + std::to_string(cy) + ") does not fit in the image");
  return g(r).clone();
}

TemplateMatch MatchTemplateNcc(const cv::Mat& image, const cv::Mat& templ, double min_score, const cv::Rect& search) {
  const cv::Mat g = Grey(image);
  const cv::Mat t = Grey(templ);
  TemplateMatch m;
  const int hx = t.cols / 2, hy = t.rows / 2;
  // The image region whose template placements have their centres inside `search`.
  cv::Rect region(0, 0, g.cols, g.rows);
  if (search.area() > 0) {
    region = cv::Rect(search.x - hx, search.y - hy, search.width + t.cols - 1, search.height + t.rows - 1) &
             cv::Rect(0, 0, g.cols, g.rows);
  }
  if (region.width < t.cols || region.height < t.rows) return m;
  cv::Mat score;
  cv::matchTemplate(g(region), t, score, cv::TM_CCOEFF_NORMED);
  double max_v = 0;
  cv::Point max_p;
  cv::minMaxLoc(score, nullptr, &max_v, nullptr, &max_p);
  m.score = max_v;
  if (max_v < min_score) return m;
  auto at = [&](int x, int y) { return double(score.at<float>(y, x)); };
  double dx = 0, dy = 0;
  if (max_p.x > 0 && max_p.x < score.cols - 1) {
    const double l = at(max_p.x - 1, max_p.y), c = at(max_p.x, max_p.y), r = at(max_p.x + 1, max_p.y);
    const double den = l - 2 * c + r;
    if (den < 0) dx = std::clamp(0.5 * (l - r) / den, -0.5, 0.5);
  }
  if (max_p.y > 0 && max_p.y < score.rows - 1) {
    const double u = at(max_p.x, max_p.y - 1), c = at(max_p.x, max_p.y), d = at(max_p.x, max_p.y + 1);
    const double den = u - 2 * c + d;
    if (den < 0) dy = std::clamp(0.5 * (u - d) / den, -0.5, 0.5);
  }
  m.found = true;
  m.centre = Eigen::Vector2d(region.x + max_p.x + dx + hx, region.y + max_p.y + dy + hy);
  return m;
}

}  // namespace owlcal::calib
