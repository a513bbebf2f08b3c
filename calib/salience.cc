#include "calib/salience.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

// Centre-surround: G_inner * m - G_outer * m.
cv::Mat Dog(const cv::Mat& m, int inner, int outer) {
  cv::Mat a, b;
  cv::GaussianBlur(m, a, cv::Size(inner, inner), 0);
  cv::GaussianBlur(m, b, cv::Size(outer, outer), 0);
  return a - b;
}

// Itti's N(.): scaled to [0, 1], times (1 - mean of the other local maxima)^2.
cv::Mat Normalise(const cv::Mat& m, double min_channel, int neighbourhood) {
  double lo, hi;
  cv::minMaxLoc(m, &lo, &hi);
  if (!(hi >= min_channel)) return cv::Mat::zeros(m.size(), CV_32F);
  cv::Mat n = m / hi;
  cv::Mat dil;
  cv::dilate(n, dil, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(neighbourhood, neighbourhood)));
  double sum = 0, top = 0;
  int count = 0;
  for (int y = 0; y < n.rows; ++y)
    for (int x = 0; x < n.cols; ++x) {
      const float v = n.at<float>(y, x);
      if (v < 0.05f || v < dil.at<float>(y, x)) continue;
      sum += v;
      ++count;
      top = std::max(top, double(v));
    }
  // The global maximum (1) is one of them; the mean is over the others.
  const double mean_others = count > 1 ? (sum - top) / (count - 1) : 0.0;
  return n * ((1 - mean_others) * (1 - mean_others));
}

double ParabolaPeak(float a, float b, float c) {
  const double d = double(a) - 2.0 * b + c;
  if (std::abs(d) < 1e-12) return 0;
  return std::clamp(0.5 * (double(a) - c) / d, -0.5, 0.5);
}

}  // namespace

bool SalienceOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "salience options: " + m;
    return false;
  };
  if (dog_inner_px < 3 || dog_outer_px <= dog_inner_px) return fail("need 3 <= dog_inner_px < dog_outer_px");
  if (intensity_weight < 0 || colour_weight < 0 || orientation_weight < 0 ||
      intensity_weight + colour_weight + orientation_weight <= 0)
    return fail("channel weights must be >= 0 and not all zero");
  if (num_candidates < 1) return fail("num_candidates must be >= 1");
  if (!(inhibition_radius_px > 0)) return fail("inhibition_radius_px must be > 0");
  if (!(min_score_fraction >= 0 && min_score_fraction <= 1)) return fail("min_score_fraction must be in [0, 1]");
  if (border_px < 0) return fail("border_px must be >= 0");
  return true;
}

SalienceMap ComputeSalience(const cv::Mat& image, const SalienceOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  if (image.empty()) throw std::invalid_argument("salience: empty image");
  cv::Mat bgr;
  if (image.channels() == 1)
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  else
    bgr = image;
  cv::Mat small;
  cv::pyrDown(bgr, small);
  SalienceMap out;
  out.scale = double(image.cols) / small.cols;
  const int inner = o.dog_inner_px | 1, outer = o.dog_outer_px | 1;
  const int neighbourhood = std::max(3, int(std::lround(o.inhibition_radius_px / out.scale)) | 1);

  cv::Mat grey, hsv, intensity;
  cv::cvtColor(small, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(intensity, CV_32F, 1.0 / 255);
  cv::cvtColor(small, hsv, cv::COLOR_BGR2HSV);
  cv::Mat channels[3];
  cv::split(hsv, channels);
  cv::Mat saturation;
  channels[1].convertTo(saturation, CV_32F, 1.0 / 255);

  out.intensity = Normalise(cv::abs(Dog(intensity, inner, outer)), o.min_channel, neighbourhood);
  out.colour = Normalise(cv::abs(Dog(saturation, inner, outer)), o.min_channel, neighbourhood);
  out.orientation = cv::Mat::zeros(intensity.size(), CV_32F);
  for (int k = 0; k < 4; ++k) {
    const cv::Mat gabor = cv::getGaborKernel(cv::Size(11, 11), 2.5, k * CV_PI / 4, 6.0, 0.5, 0, CV_32F);
    cv::Mat response;
    cv::filter2D(intensity, response, CV_32F, gabor);
    cv::Mat energy = cv::max(Dog(cv::abs(response), inner, outer), 0.0);
    out.orientation += Normalise(energy, o.min_channel, neighbourhood);
  }
  out.orientation = Normalise(out.orientation, o.min_channel, neighbourhood);
  const double wsum = o.intensity_weight + o.colour_weight + o.orientation_weight;
  out.map =
      (o.intensity_weight * out.intensity + o.colour_weight * out.colour + o.orientation_weight * out.orientation) /
      wsum;

  // Candidates with inhibition of return.
  cv::Mat work = out.map.clone();
  const int border = int(std::ceil(o.border_px / out.scale));
  if (border > 0) {
    work.rowRange(0, std::min(border, work.rows)).setTo(0);
    work.rowRange(std::max(0, work.rows - border), work.rows).setTo(0);
    work.colRange(0, std::min(border, work.cols)).setTo(0);
    work.colRange(std::max(0, work.cols - border), work.cols).setTo(0);
  }
  const double radius = o.inhibition_radius_px / out.scale;
  double first = 0;
  while (int(out.candidates.size()) < o.num_candidates) {
    double v;
    cv::Point p;
    cv::minMaxLoc(work, nullptr, &v, nullptr, &p);
    if (!(v > 0) || (first > 0 && v < o.min_score_fraction * first)) break;
    if (first == 0) first = v;
    double dx = 0, dy = 0;
    if (p.x > 0 && p.x < out.map.cols - 1)
      dx = ParabolaPeak(out.map.at<float>(p.y, p.x - 1), out.map.at<float>(p.y, p.x), out.map.at<float>(p.y, p.x + 1));
    if (p.y > 0 && p.y < out.map.rows - 1)
      dy = ParabolaPeak(out.map.at<float>(p.y - 1, p.x), out.map.at<float>(p.y, p.x), out.map.at<float>(p.y + 1, p.x));
    SalienceCandidate c;
    // pyrDown: map pixel (x, y) is centred on full pixel (scale x, scale y).
    c.px = Eigen::Vector2d((p.x + dx) * out.scale, (p.y + dy) * out.scale);
    c.score = v;
    c.intensity = out.intensity.at<float>(p);
    c.colour = out.colour.at<float>(p);
    c.orientation = out.orientation.at<float>(p);
    out.candidates.push_back(c);
    cv::circle(work, p, int(std::ceil(radius)), cv::Scalar(0), cv::FILLED);
  }
  return out;
}

}  // namespace owlcal::calib
