#include "calib/stereo_match.h"
#include "io/number_text.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

cv::Mat MatchGrey(const cv::Mat& m) {
  cv::Mat g;
  if (m.channels() == 3)
    cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
  else if (m.channels() == 4)
    cv::cvtColor(m, g, cv::COLOR_BGRA2GRAY);
  else
    g = m;
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

const char* ToString(MatchConfidence c) {
  switch (c) {
    case MatchConfidence::kOk:
      return "ok";
    case MatchConfidence::kLowConfidence:
      return "low_confidence";
    case MatchConfidence::kFailed:
      return "failed";
  }
  return "failed";
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
  if (!(low_ncc >= min_ncc && low_ncc < 1)) return fail("low_ncc must be in [min_ncc, 1)");
  if (noise_sigma < 0 || subpixel_floor_px < 0) return fail("noise_sigma and subpixel_floor_px must be >= 0");
  if (!(min_contrast >= 0 && max_sigma_disparity_low_px > 0 &&
        max_sigma_disparity_fail_px >= max_sigma_disparity_low_px))
    return fail("min_contrast >= 0 and 0 < max_sigma_disparity_low_px <= max_sigma_disparity_fail_px");
  if (!(lr_tolerance_px > 0 && lr_fail_px >= lr_tolerance_px)) return fail("0 < lr_tolerance_px <= lr_fail_px");
  if (!(peak_ratio_low > 0 && peak_ratio_fail >= peak_ratio_low && peak_ratio_fail <= 1))
    return fail("0 < peak_ratio_low <= peak_ratio_fail <= 1");
  if (!(block_tolerance_px > 0 && block_tolerance_fraction >= 0))
    return fail("block_tolerance_px must be > 0 and block_tolerance_fraction >= 0");
  return true;
}

namespace {

struct Peak {
  bool ok = false;
  std::string message;
  double x = 0, y = 0;  // sub-pixel top-left of the match in the searched image
  double ncc = -1, second = -1;
  bool at_edge = false;  // the peak sits at the end of the x range
  bool at_row_edge = false;
};

// Searches `templ` in `img` over top-left positions x in [x_lo, x_hi], y in [y_lo, y_hi]
// (clipped to the image) by TM_CCOEFF_NORMED; sub-pixel by parabolas; the second distinct peak
// from the column profile (max over rows) outside the main lobe.
Peak Search(const cv::Mat& templ, const cv::Mat& img, int x_lo, int x_hi, int y_lo, int y_hi) {
  Peak p;
  const int w = templ.cols, h = templ.rows;
  x_lo = std::max(0, x_lo);
  x_hi = std::min(img.cols - w, x_hi);
  y_lo = std::max(0, y_lo);
  y_hi = std::min(img.rows - h, y_hi);
  if (x_hi - x_lo < 2 || y_hi < y_lo) {
    p.message = "search strip too small (template near the image edge)";
    return p;
  }
  cv::Mat score;
  cv::matchTemplate(img(cv::Rect(x_lo, y_lo, x_hi - x_lo + w, y_hi - y_lo + h)), templ, score, cv::TM_CCOEFF_NORMED);
  double best;
  cv::Point at;
  cv::minMaxLoc(score, nullptr, &best, nullptr, &at);
  p.ncc = best;
  std::vector<double> prof(score.cols, -1);
  for (int r = 0; r < score.rows; ++r)
    for (int c = 0; c < score.cols; ++c) prof[c] = std::max(prof[c], static_cast<double>(score.at<float>(r, c)));
  int lo = at.x, hi = at.x;
  while (lo > 0 && prof[lo - 1] < prof[lo]) --lo;
  while (hi < score.cols - 1 && prof[hi + 1] < prof[hi]) ++hi;
  for (int c = 0; c < score.cols; ++c) {
    if (c >= lo && c <= hi) continue;
    const bool local_max = (c == 0 || prof[c] >= prof[c - 1]) && (c == score.cols - 1 || prof[c] >= prof[c + 1]);
    if (local_max) p.second = std::max(p.second, prof[c]);
  }
  if (at.x == 0 || at.x == score.cols - 1) {
    p.at_edge = true;
    p.message = "NCC peak at the end of the disparity range";
    return p;
  }
  const double dx =
      ParabolaPeakOffset(score.at<float>(at.y, at.x - 1), score.at<float>(at.y, at.x), score.at<float>(at.y, at.x + 1));
  double dyo = 0;
  if (at.y > 0 && at.y < score.rows - 1)
    dyo = ParabolaPeakOffset(
        score.at<float>(at.y - 1, at.x), score.at<float>(at.y, at.x), score.at<float>(at.y + 1, at.x));
  p.at_row_edge = score.rows > 1 && (at.y == 0 || at.y == score.rows - 1);
  p.x = x_lo + at.x + dx;
  p.y = y_lo + at.y + dyo;
  p.ok = true;
  return p;
}

std::string Num(double v, int decimals = 2) { return io::FixedText(v, decimals); }

}  // namespace

StereoMatch MatchAlongRow(const cv::Mat& left_rect, const cv::Mat& right_rect, const StereoMatchOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("StereoMatchOptions: " + why);
  if (left_rect.empty() || right_rect.empty() || left_rect.size() != right_rect.size())
    throw std::invalid_argument("MatchAlongRow: images empty or of different sizes");
  const cv::Mat left = MatchGrey(left_rect), right = MatchGrey(right_rect);
  StereoMatch m;
  m.lr_error_px = std::numeric_limits<double>::quiet_NaN();
  cv::Rect roi = o.template_roi;
  if (roi.area() == 0) {
    roi = cv::Rect(
        (left.cols - o.template_width) / 2, (left.rows - o.template_height) / 2, o.template_width, o.template_height);
  }
  m.template_roi = roi;
  auto fail = [&](const std::string& why_failed) {
    m.confidence = MatchConfidence::kFailed;
    m.flags.push_back(why_failed);
    m.message = why_failed;
    return m;
  };
  if ((roi & cv::Rect(0, 0, left.cols, left.rows)) != roi) return fail("template ROI outside the image");
  m.left_px = cv::Point2d(roi.x + (roi.width - 1) / 2.0, roi.y + (roi.height - 1) / 2.0);
  const cv::Mat templ = left(roi);
  cv::Scalar mean, stdev;
  cv::meanStdDev(templ, mean, stdev);
  m.contrast = stdev[0];

  // Forward: the left template along the right image's rows.
  const Peak f = Search(
      templ, right, roi.x - o.max_disparity, roi.x - o.min_disparity, roi.y - o.row_search, roi.y + o.row_search);
  m.ncc = f.ncc;
  m.second_ncc = f.second;
  m.peak_ratio = f.ncc > 0 && f.second > 0 ? f.second / f.ncc : 0;
  if (!f.ok) return fail(f.message);
  m.right_px = cv::Point2d(f.x + (roi.width - 1) / 2.0, f.y + (roi.height - 1) / 2.0);
  m.disparity_px = m.left_px.x - m.right_px.x;
  m.dy_px = m.right_px.y - m.left_px.y;

  // Matching sigma: Cramer-Rao for a shift between two noisy copies, plus the sub-pixel floor.
  cv::Mat gx;
  cv::Sobel(templ, gx, CV_64F, 1, 0, 3, 1.0 / 8.0);  // scaled to a central difference
  const double sum_g2 = cv::sum(gx.mul(gx))[0];
  m.noise_sigma = o.noise_sigma > 0 ? o.noise_sigma : EstimateNoise(templ);
  const double crb2 = sum_g2 > 0 ? 2 * m.noise_sigma * m.noise_sigma / sum_g2 : 1e6;

  // Left-right check: the matched right region searched for in the left image.
  const int rx = static_cast<int>(std::lround(f.x)), ry = static_cast<int>(std::lround(f.y));
  if (rx >= 0 && ry >= 0 && rx + roi.width <= right.cols && ry + roi.height <= right.rows) {
    const Peak b = Search(right(cv::Rect(rx, ry, roi.width, roi.height)),
                          left,
                          rx + o.min_disparity,
                          rx + o.max_disparity,
                          ry - o.row_search,
                          ry + o.row_search);
    // Consistent: the back-match lands at roi.x, moved by the fraction the forward match had.
    if (b.ok)
      m.lr_error_px = std::abs(b.x - (roi.x + rx - f.x));
    else
      m.lr_error_px = std::numeric_limits<double>::infinity();
  }
  const double lr2 = std::isfinite(m.lr_error_px) ? 0.25 * m.lr_error_px * m.lr_error_px : 0;
  m.sigma_disparity_px = std::sqrt(crb2 + o.subpixel_floor_px * o.subpixel_floor_px + lr2);

  // The four quarters of the template, matched alone.
  if (o.check_blocks && roi.width >= 16 && roi.height >= 16) {
    const int hw = roi.width / 2, hh = roi.height / 2;
    for (int q = 0; q < 4; ++q) {
      const cv::Rect sub(roi.x + (q % 2) * hw, roi.y + (q / 2) * hh, hw, hh);
      const Peak s = Search(left(sub),
                            right,
                            sub.x - o.max_disparity,
                            sub.x - o.min_disparity,
                            sub.y - o.row_search,
                            sub.y + o.row_search);
      if (!s.ok || s.ncc < o.min_ncc) continue;
      ++m.blocks_used;
      m.block_spread_px = std::max(m.block_spread_px, std::abs((sub.x - s.x) - (roi.x - f.x)));
    }
  }

  // Confidence.
  bool failed = false, low = false;
  auto flag = [&](bool is_fail, const std::string& text) {
    (is_fail ? failed : low) = true;
    m.flags.push_back(text);
  };
  if (f.ncc < o.min_ncc)
    flag(true, "best NCC " + Num(f.ncc, 3) + " < " + Num(o.min_ncc, 2));
  else if (f.ncc < o.low_ncc)
    flag(false, "weak match: NCC " + Num(f.ncc, 3) + " < " + Num(o.low_ncc, 2));
  if (m.contrast < o.min_contrast)
    flag(true,
         "no texture in the template (grey-level std " + Num(m.contrast, 1) + " < " + Num(o.min_contrast, 1) + ")");
  const double sd = std::sqrt(crb2);
  if (sd > o.max_sigma_disparity_fail_px)
    flag(
        true,
        "too little texture across the row: matching sigma " + Num(sd) + " px > " + Num(o.max_sigma_disparity_fail_px));
  else if (sd > o.max_sigma_disparity_low_px)
    flag(false,
         "little texture across the row: matching sigma " + Num(sd) + " px > " + Num(o.max_sigma_disparity_low_px));
  if (!(m.lr_error_px <= o.lr_fail_px))
    flag(true,
         "left-right check: the right patch matches back " +
             (std::isfinite(m.lr_error_px) ? Num(m.lr_error_px, 1) + " px" : std::string("nowhere")) +
             " from the template (> " + Num(o.lr_fail_px, 1) + " px)");
  else if (m.lr_error_px > o.lr_tolerance_px)
    flag(false, "left-right check off by " + Num(m.lr_error_px) + " px (> " + Num(o.lr_tolerance_px, 1) + ")");
  if (m.peak_ratio > o.peak_ratio_fail)
    flag(true,
         "ambiguous: a second peak at NCC " + Num(f.second, 3) + " (" + Num(100 * m.peak_ratio, 0) +
             " % of the best): repeated texture");
  else if (m.peak_ratio > o.peak_ratio_low)
    flag(false, "a second peak at NCC " + Num(f.second, 3) + " (" + Num(100 * m.peak_ratio, 0) + " % of the best)");
  const double block_tol = std::max(o.block_tolerance_px, o.block_tolerance_fraction * std::abs(m.disparity_px));
  if (m.block_spread_px > block_tol)
    flag(false,
         "the template spans several depths: a quarter of it matches " + Num(m.block_spread_px, 1) +
             " px away from the whole (> " + Num(block_tol, 1) + " px; a target's edge against the background?)");
  if (f.at_row_edge && o.row_search > 0)
    flag(false, "best row at the edge of the row search (dy " + Num(m.dy_px, 1) + " px): rectification off?");
  m.confidence = failed ? MatchConfidence::kFailed : (low ? MatchConfidence::kLowConfidence : MatchConfidence::kOk);
  m.found = !failed;
  for (size_t i = 0; i < m.flags.size(); ++i) m.message += (i ? "; " : "") + m.flags[i];
  return m;
}

}  // namespace owlcal::calib
