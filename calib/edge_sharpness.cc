#include "calib/edge_sharpness.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include "models/statistics.h"

namespace owlcal::calib {
namespace {

// The q-quantile (0..1) of v by linear interpolation between order statistics.
double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const size_t i = size_t(pos);
  const double f = pos - double(i);
  return i + 1 < v.size() ? v[i] + f * (v[i + 1] - v[i]) : v[i];
}

// Bilinear sample of a CV_32F image; false outside.
bool SampleBilinear(const cv::Mat& f, double x, double y, double* out) {
  if (!(x >= 0 && y >= 0 && x <= f.cols - 1 && y <= f.rows - 1)) return false;
  const int x0 = std::min(int(x), f.cols - 2), y0 = std::min(int(y), f.rows - 2);
  const double ax = x - x0, ay = y - y0;
  const float* r0 = f.ptr<float>(y0);
  const float* r1 = f.ptr<float>(y0 + 1);
  const double top = r0[x0] + ax * (r0[x0 + 1] - r0[x0]);
  const double bottom = r1[x0] + ax * (r1[x0 + 1] - r1[x0]);
  *out = top + ay * (bottom - top);
  return true;
}

// Least-squares fit of I(d) = m + (a / 2) erf((d - d0) / (sqrt(2) s)) to an edge profile
// (Gauss-Newton with step halving on m, a, d0, log s).
struct EdgeFit {
  bool ok = false;
  double step = 0, d0 = 0, sigma = 0, rms = 0;
};

EdgeFit FitEdgeProfile(const std::vector<std::pair<double, double>>& p) {
  EdgeFit out;
  if (p.size() < 8) return out;
  double lo = 0, hi = 0, sum = 0;
  int nlo = 0, nhi = 0;
  for (const auto& [d, v] : p) {
    sum += v;
    if (d < -1) lo += v, ++nlo;
    if (d > 1) hi += v, ++nhi;
  }
  if (!nlo || !nhi) return out;
  double th[4] = {sum / double(p.size()), hi / nhi - lo / nlo, 0.0, 0.0};  // m, a, d0, log s
  auto cost = [&](const double* q) {
    double c = 0;
    const double sg = std::exp(q[3]);
    for (const auto& [d, v] : p) {
      const double r = q[0] + 0.5 * q[1] * std::erf((d - q[2]) / (std::sqrt(2.0) * sg)) - v;
      c += r * r;
    }
    return c;
  };
  double c = cost(th);
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    const double sg = std::exp(th[3]);
    for (const auto& [d, v] : p) {
      const double z = (d - th[2]) / (std::sqrt(2.0) * sg);
      const double e = std::erf(z), g = 2.0 / std::sqrt(M_PI) * std::exp(-z * z);
      const double r = th[0] + 0.5 * th[1] * e - v;
      // d r / d (m, a, d0, log s)
      const Eigen::Vector4d j(1.0, 0.5 * e, -0.5 * th[1] * g / (std::sqrt(2.0) * sg), -0.5 * th[1] * g * z);
      jtj += j * j.transpose();
      jtr += j * r;
    }
    jtj.diagonal() *= 1.0 + 1e-6;
    const Eigen::Vector4d delta = jtj.ldlt().solve(-jtr);
    if (!delta.allFinite()) return out;
    double lambda = 1;
    bool improved = false;
    for (int h = 0; h < 8; ++h, lambda *= 0.5) {
      double q[4];
      for (int k = 0; k < 4; ++k) q[k] = th[k] + lambda * delta[k];
      q[3] = std::clamp(q[3], std::log(0.05), std::log(20.0));
      const double cq = cost(q);
      if (cq < c) {
        std::copy(q, q + 4, th);
        improved = c - cq > 1e-10 * (1 + c);
        c = cq;
        break;
      }
    }
    if (!improved) break;
  }
  out.step = th[1];
  out.d0 = th[2];
  out.sigma = std::exp(th[3]);
  out.rms = std::sqrt(c / double(p.size()));
  out.ok = std::isfinite(out.sigma) && std::isfinite(out.step);
  return out;
}

}  // namespace

bool EdgeSharpnessOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "EdgeSharpnessOptions." + m;
    return false;
  };
  if (!(probe_px >= 2 && probe_px <= 20)) return fail("probe_px must be in [2, 20]");
  if (!(min_step > 0 && min_step < 255)) return fail("min_step must be in (0, 255)");
  if (!(max_fit_rms_fraction > 0 && max_fit_rms_fraction < 0.5))
    return fail("max_fit_rms_fraction must be in (0, 0.5)");
  if (!(min_gradient_fraction > 0 && min_gradient_fraction < 1)) return fail("min_gradient_fraction must be in (0, 1)");
  if (min_edges < 1) return fail("min_edges must be >= 1");
  return true;
}

EdgeSharpness MeasureEdgeSharpness(const cv::Mat& image, const cv::Rect& roi_in, const EdgeSharpnessOptions& o) {
  EdgeSharpness s;
  std::string why;
  if (!o.Check(&why)) {
    s.reason = why;
    return s;
  }
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3)) {
    s.reason = "image is not an 8-bit grey or BGR image";
    return s;
  }
  s.roi = roi_in & cv::Rect(0, 0, image.cols, image.rows);
  const int margin = int(std::ceil(o.probe_px)) + 2;
  if (s.roi.width < 2 * margin + 4 || s.roi.height < 2 * margin + 4) {
    s.reason = "region " + std::to_string(s.roi.width) + "x" + std::to_string(s.roi.height) +
               " px is too small (at least " + std::to_string(2 * margin + 4) + " px a side)";
    return s;
  }
  cv::Mat grey;
  if (image.channels() == 3)
    cv::cvtColor(image(s.roi), grey, cv::COLOR_BGR2GRAY);
  else
    grey = image(s.roi);
  cv::Mat f;
  grey.convertTo(f, CV_32F);

  // Contrast and the (normalised) Laplacian variance over the region.
  std::vector<double> values;
  values.reserve(size_t(f.total()));
  for (int y = 0; y < f.rows; ++y)
    for (int x = 0; x < f.cols; ++x) values.push_back(f.at<float>(y, x));
  s.contrast = Quantile(values, 0.95) - Quantile(values, 0.05);
  {
    cv::Mat lap;
    cv::Laplacian(f, lap, CV_32F, 1);
    cv::Scalar mean, dev;
    cv::meanStdDev(lap(cv::Rect(1, 1, lap.cols - 2, lap.rows - 2)), mean, dev);
    s.laplacian_variance = s.contrast > 0 ? dev[0] * dev[0] / (s.contrast * s.contrast) : 0;
  }

  cv::Mat gx, gy;
  cv::Sobel(f, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(f, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  cv::Mat mag;
  cv::magnitude(gx, gy, mag);
  std::vector<double> inner;
  for (int y = margin; y < f.rows - margin; ++y)
    for (int x = margin; x < f.cols - margin; ++x) inner.push_back(mag.at<float>(y, x));
  const double threshold = o.min_gradient_fraction * Quantile(inner, 0.99);
  if (!(threshold > 0)) {
    s.reason = "no edges in the region (flat image)";
    return s;
  }

  std::vector<double> sigmas;
  const int R = int(std::ceil(o.probe_px)) + 1;
  std::vector<std::pair<double, double>> profile;  // (signed distance along n, grey)
  for (int y = margin; y < f.rows - margin; ++y) {
    for (int x = margin; x < f.cols - margin; ++x) {
      const float m0 = mag.at<float>(y, x);
      if (m0 < threshold) continue;
      const double nx = gx.at<float>(y, x) / m0, ny = gy.at<float>(y, x) / m0;
      // Non-maximum suppression along n (bilinear magnitude one pixel either side).
      double mp, mm;
      if (!SampleBilinear(mag, x + nx, y + ny, &mp) || !SampleBilinear(mag, x - nx, y - ny, &mm)) continue;
      if (!(m0 >= mp && m0 > mm)) continue;
      ++s.num_candidates;
      // Sub-pixel centre along n: vertex of the parabola through (-1, mm), (0, m0), (1, mp).
      const double den = mm - 2 * m0 + mp;
      const double t = den < 0 ? std::clamp(0.5 * (mm - mp) / den, -0.5, 0.5) : 0.0;
      const double cx = x + t * nx, cy = y + t * ny;
      // The edge spread function from the pixels themselves (no interpolation, which would
      // add its own blur): every pixel within probe_px of the centre along n and 1.5 px across.
      profile.clear();
      for (int v = std::max(0, y - R); v <= std::min(f.rows - 1, y + R); ++v)
        for (int u = std::max(0, x - R); u <= std::min(f.cols - 1, x + R); ++u) {
          const double d = (u - cx) * nx + (v - cy) * ny, e = -(u - cx) * ny + (v - cy) * nx;
          if (std::abs(d) <= o.probe_px && std::abs(e) <= 1.5) profile.emplace_back(d, f.at<float>(v, u));
        }
      const EdgeFit fit = FitEdgeProfile(profile);
      if (!fit.ok || fit.step < o.min_step) continue;
      // An isolated straight step: the erf explains the profile (corners, lines and texture
      // do not), and the blur is small enough for the window to hold both plateaus.
      if (fit.rms > o.max_fit_rms_fraction * fit.step || fit.sigma > o.probe_px / 1.5 || std::abs(fit.d0) > 1.0)
        continue;
      sigmas.push_back(fit.sigma);
    }
  }
  s.num_edges = int(sigmas.size());
  if (s.num_edges < o.min_edges) {
    s.reason = "too few isolated edges: " + std::to_string(s.num_edges) + " of " + std::to_string(s.num_candidates) +
               " edge points (need " + std::to_string(o.min_edges) + ")";
    return s;
  }
  s.blur_sigma_px = models::Median(sigmas);
  s.blur_sigma_iqr_px = Quantile(sigmas, 0.75) - Quantile(sigmas, 0.25);
  // Standard error of a median: 1.2533 * sigma / sqrt(n), with sigma = IQR / 1.349. Edge
  // points a pixel apart share pixels of their windows: count one point in three.
  const double n_eff = std::max(1.0, s.num_edges / 3.0);
  s.blur_sigma_se_px = 1.2533 * (s.blur_sigma_iqr_px / 1.349) / std::sqrt(n_eff);
  s.ok = true;
  return s;
}

}  // namespace owlcal::calib
