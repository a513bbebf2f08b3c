#include "calib/stereo_match.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

cv::Mat ToGrey(const cv::Mat& m) {
  cv::Mat g;
  if (m.channels() == 3) cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
  else if (m.channels() == 4) cv::cvtColor(m, g, cv::COLOR_BGRA2GRAY);
  else g = m;
  if (g.depth() != CV_8U) throw std::invalid_argument("MatchAlongRow: images must be 8-bit");
  return g;
}

// Immerkaer's fast noise estimate: sigma = sqrt(pi/2) / (6 (W-2)(H-2)) * sum |I * N|.
double EstimateNoise(const cv::Mat& grey) {
  if (grey.cols < 3 || grey.rows < 3) return 1.0;
  cv::Mat f;
  grey.convertTo(f, CV_64F);
  const cv::Mat kernel = (cv::Mat_<double>(3, 3) << 1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat r;
  cv::filter2D(f, r, CV_64F, kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
  const cv::Mat inner = cv::abs(r(cv::Rect(1, 1, grey.cols - 2, grey.rows - 2)));
  const double s = cv::sum(inner)[0];
  return std::sqrt(M_PI / 2) * s / (6.0 * (grey.cols - 2) * (grey.rows - 2));
}

}  // namespace

double ParabolaPeakOffset(double l, double c, double r) {
  const double den = l - 2 * c + r;
  if (!(den < 0)) return 0;  // not a maximum
  return std::clamp(0.5 * (l - r) / den, -0.5, 0.5);
}

bool StereoMatchOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (template_roi.area() == 0 && (template_width < 5 || template_height < 5))
    return fail("template_width/height = " + std::to_string(template_width) + "x" + std::to_string(template_height) +
                " must be >= 5");
  if (min_disparity < 0 || max_disparity <= min_disparity)
    return fail("disparity range [" + std::to_string(min_disparity) + ", " + std::to_string(max_disparity) +
                "] must satisfy 0 <= min < max");
  if (row_search < 0) return fail("row_search = " + std::to_string(row_search) + " must be >= 0");
  if (!(min_ncc > -1 && min_ncc < 1)) return fail("min_ncc = " + std::to_string(min_ncc) + " must be in (-1, 1)");
  if (noise_sigma < 0 || subpixel_floor_px < 0) return fail("noise_sigma and subpixel_floor_px must be >= 0");
  return true;
}

StereoMatch MatchAlongRow(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoMatchOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("StereoMatchOptions: " + why);
  if (left_rect.empty() || right_rect.empty() || left_rect.size() != right_rect.size())
    throw std::invalid_argument("MatchAlongRow: images empty or of different sizes");
  const cv::Mat left = ToGrey(left_rect), right = ToGrey(right_rect);
  StereoMatch m;
  cv::Rect roi = o.template_roi;
  if (roi.area() == 0) {
    roi = cv::Rect((left.cols - o.template_width) / 2, (left.rows - o.template_height) / 2, o.template_width,
                   o.template_height);
  }
  m.template_roi = roi;
  if ((roi & cv::Rect(0, 0, left.cols, left.rows)) != roi) {
    m.message = "template ROI outside the image";
    return m;
  }
  m.left_px = cv::Point2d(roi.x + (roi.width - 1) / 2.0, roi.y + (roi.height - 1) / 2.0);
  // Search strip in the right image: columns x - max_d .. x - min_d (+ template width), rows
  // y - row_search .. y + row_search (+ template height), clipped to the image.
  const int x0 = std::max(0, roi.x - o.max_disparity);
  const int x1 = std::min(right.cols, roi.x - o.min_disparity + roi.width);
  const int y0 = std::max(0, roi.y - o.row_search);
  const int y1 = std::min(right.rows, roi.y + o.row_search + roi.height);
  if (x1 - x0 < roi.width + 2 || y1 - y0 < roi.height) {
    m.message = "search strip too small (template near the image edge)";
    return m;
  }
  const cv::Mat templ = left(roi);
  cv::Mat score;
  cv::matchTemplate(right(cv::Rect(x0, y0, x1 - x0, y1 - y0)), templ, score, cv::TM_CCOEFF_NORMED);
  double best;
  cv::Point at;
  cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
  m.ncc = best;
  // Second best peak: outside +-3 px in x of the best.
  double second = -1;
  for (int r = 0; r < score.rows; ++r)
    for (int c = 0; c < score.cols; ++c)
      if (std::abs(c - at.x) > 3) second = std::max(second, static_cast<double>(score.at<float>(r, c)));
  m.second_ncc = second;
  if (best < o.min_ncc) {
    m.message = "best NCC " + std::to_string(best) + " < min_ncc " + std::to_string(o.min_ncc);
    return m;
  }
  if (at.x == 0 || at.x == score.cols - 1) {
    m.message = "NCC peak at the end of the disparity range";
    return m;
  }
  const double dx = ParabolaPeakOffset(score.at<float>(at.y, at.x - 1), score.at<float>(at.y, at.x),
                                       score.at<float>(at.y, at.x + 1));
  double dyo = 0;
  if (at.y > 0 && at.y < score.rows - 1)
    dyo = ParabolaPeakOffset(score.at<float>(at.y - 1, at.x), score.at<float>(at.y, at.x),
                             score.at<float>(at.y + 1, at.x));
  const double rx = x0 + at.x + dx, ry = y0 + at.y + dyo;
  m.right_px = cv::Point2d(rx + (roi.width - 1) / 2.0, ry + (roi.height - 1) / 2.0);
  m.disparity_px = m.left_px.x - m.right_px.x;
  m.dy_px = m.right_px.y - m.left_px.y;
  // Matching sigma: Cramer-Rao for a shift between two noisy copies, plus the sub-pixel floor.
  cv::Mat gx;
  cv::Sobel(templ, gx, CV_64F, 1, 0, 3, 1.0 / 8.0);  // scaled to a central difference
  const double sum_g2 = cv::sum(gx.mul(gx))[0];
  m.noise_sigma = o.noise_sigma > 0 ? o.noise_sigma : EstimateNoise(templ);
  const double crb2 = sum_g2 > 0 ? 2 * m.noise_sigma * m.noise_sigma / sum_g2 : 1e6;
  m.sigma_disparity_px = std::sqrt(crb2 + o.subpixel_floor_px * o.subpixel_floor_px);
  m.found = true;
  return m;
}

}  // namespace owlcal::calib
