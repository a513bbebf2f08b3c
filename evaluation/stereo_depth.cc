#include "evaluation/stereo_depth.h"
#include "models/statistics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <Eigen/Dense>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "models/units.h"

namespace owlcal::evaluation {
namespace {

using models::Median;

cv::Mat Grey(const cv::Mat& m) {
  if (m.channels() == 1) return m;
  cv::Mat g;
  cv::cvtColor(m, g, m.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return g;
}

}  // namespace

bool SgbmOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "SgbmOptions." + m;
    return false;
  };
  if (num_disparities <= 0 || num_disparities % 16 != 0)
    return fail("num_disparities must be a positive multiple of 16, got " + std::to_string(num_disparities));
  if (block_size < 1 || block_size > 31 || block_size % 2 == 0)
    return fail("block_size must be odd and 1..31, got " + std::to_string(block_size));
  if (p1 < 0 || p2 < 0) return fail("p1, p2 must be >= 0 (0 = default)");
  if (P2() <= P1()) return fail("p2 (" + std::to_string(P2()) + ") must exceed p1 (" + std::to_string(P1()) + ")");
  if (pre_filter_cap < 1 || pre_filter_cap > 63)
    return fail("pre_filter_cap must be 1..63, got " + std::to_string(pre_filter_cap));
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100)
    return fail("uniqueness_ratio must be 0..100, got " + std::to_string(uniqueness_ratio));
  if (speckle_window_size < 0) return fail("speckle_window_size must be >= 0");
  if (speckle_range < 0) return fail("speckle_range must be >= 0");
  if (mode != "sgbm" && mode != "hh" && mode != "3way" && mode != "hh4")
    return fail("mode must be sgbm, hh, 3way or hh4, got '" + mode + "'");
  return true;
}

bool DepthOptions::Check(std::string* why) const {
  if (!sgbm.Check(why)) return false;
  auto fail = [&](const std::string& m) {
    if (why) *why = "DepthOptions." + m;
    return false;
  };
  if (!(rectify_alpha == -1 || (rectify_alpha >= 0 && rectify_alpha <= 1)))
    return fail("rectify_alpha must be -1 or 0..1, got " + std::to_string(rectify_alpha));
  if (!(subpixel_floor_px >= 0)) return fail("subpixel_floor_px must be >= 0");
  if (!(min_valid_fraction > 0 && min_valid_fraction <= 1)) return fail("min_valid_fraction must be in (0, 1]");
  if (!(max_depth_m > 0)) return fail("max_depth_m must be > 0");
  return true;
}

cv::Mat SgbmDisparity16(const cv::Mat& left_rect, const cv::Mat& right_rect, const SgbmOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  const int mode = o.mode == "hh"     ? cv::StereoSGBM::MODE_HH
                   : o.mode == "3way" ? cv::StereoSGBM::MODE_SGBM_3WAY
                   : o.mode == "hh4"  ? cv::StereoSGBM::MODE_HH4
                                      : cv::StereoSGBM::MODE_SGBM;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(o.min_disparity,
                                                        o.num_disparities,
                                                        o.block_size,
                                                        o.P1(),
                                                        o.P2(),
                                                        o.disp12_max_diff,
                                                        o.pre_filter_cap,
                                                        o.uniqueness_ratio,
                                                        o.speckle_window_size,
                                                        o.speckle_range,
                                                        mode);
  cv::Mat d16;
  sgbm->compute(Grey(left_rect), Grey(right_rect), d16);
  return d16;
}

RoiAgreement DisparityAgreement(
    const cv::Mat& disparity16, const SgbmOptions& o, const cv::Rect& roi, double disparity_px, double tolerance_px) {
  RoiAgreement a;
  const cv::Rect r = roi & cv::Rect(0, 0, disparity16.cols, disparity16.rows);
  a.num_pixels = r.area();
  const int invalid = (o.min_disparity - 1) * 16;
  std::vector<double> d;
  for (int y = r.y; y < r.y + r.height; ++y) {
    const int16_t* row = disparity16.ptr<int16_t>(y);
    for (int x = r.x; x < r.x + r.width; ++x)
      if (row[x] > invalid && row[x] > 0) d.push_back(row[x] / 16.0);
  }
  a.num_valid = static_cast<int>(d.size());
  if (d.empty()) return a;
  int agree = 0;
  for (double v : d) agree += std::abs(v - disparity_px) <= tolerance_px;
  a.agreeing_fraction = double(agree) / d.size();
  a.median_px = Median(d);
  return a;
}

DepthMaps ComputeDepth(const cv::Mat& left_raw,
                       const cv::Mat& right_raw,
                       const fitting::Rectification& rect,
                       const DepthOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  if (left_raw.empty() || right_raw.empty()) throw std::invalid_argument("ComputeDepth: empty image");
  if (left_raw.size() != rect.size || right_raw.size() != rect.size)
    throw std::invalid_argument("ComputeDepth: images are " + std::to_string(left_raw.cols) + "x" +
                                std::to_string(left_raw.rows) + " / " + std::to_string(right_raw.cols) + "x" +
                                std::to_string(right_raw.rows) + ", the calibration is for " +
                                std::to_string(rect.size.width) + "x" + std::to_string(rect.size.height));
  DepthMaps m;
  fitting::RemapPair(rect, Grey(left_raw), Grey(right_raw), &m.left_rect, &m.right_rect);
  m.disparity16 = SgbmDisparity16(m.left_rect, m.right_rect, options.sgbm);
  const SgbmOptions& o = options.sgbm;
  m.focal_px = rect.P1(0, 0);
  m.cx = rect.P1(0, 2);
  m.cy = rect.P1(1, 2);
  m.baseline_m = rect.baseline_m;
  m.disparity_px.create(m.disparity16.size(), CV_32F);
  m.depth_m.create(m.disparity16.size(), CV_32F);
  // StereoSGBM marks invalid pixels with (min_disparity - 1) * 16; a disparity <= 0 has no depth.
  const int invalid = (o.min_disparity - 1) * 16;
  const float fb = float(m.focal_px * m.baseline_m);
  for (int y = 0; y < m.disparity16.rows; ++y) {
    const int16_t* d16 = m.disparity16.ptr<int16_t>(y);
    float* d = m.disparity_px.ptr<float>(y);
    float* z = m.depth_m.ptr<float>(y);
    for (int x = 0; x < m.disparity16.cols; ++x) {
      if (d16[x] <= invalid || d16[x] <= 0) {
        d[x] = z[x] = std::numeric_limits<float>::quiet_NaN();
        continue;
      }
      d[x] = d16[x] / 16.f;
      z[x] = fb / d[x];
      ++m.num_valid;
    }
  }
  return m;
}

RoiDepth DepthAtRoi(const DepthMaps& maps,
                    const cv::Rect& roi_in,
                    const fitting::StereoRig& rig,
                    const fitting::Rectification& rect,
                    const DepthOptions& options) {
  RoiDepth r;
  r.roi = roi_in & cv::Rect(0, 0, maps.disparity_px.cols, maps.disparity_px.rows);
  if (r.roi.area() <= 0) {
    r.message = "ROI lies outside the " + std::to_string(maps.disparity_px.cols) + "x" +
                std::to_string(maps.disparity_px.rows) + " rectified image";
    return r;
  }
  r.num_pixels = r.roi.area();
  std::vector<double> d, d16;
  std::vector<Eigen::Vector3d> xyd;
  for (int y = r.roi.y; y < r.roi.y + r.roi.height; ++y)
    for (int x = r.roi.x; x < r.roi.x + r.roi.width; ++x) {
      const float v = maps.disparity_px.at<float>(y, x);
      if (!std::isfinite(v)) continue;
      d.push_back(v);
      d16.push_back(maps.disparity16.at<int16_t>(y, x));
      xyd.emplace_back(x, y, v);
    }
  r.num_valid = int(d.size());
  if (r.valid_fraction() < options.min_valid_fraction || r.num_valid < 3) {
    r.message = "only " + std::to_string(r.num_valid) + " of " + std::to_string(r.num_pixels) +
                " ROI pixels have a disparity (needs " + std::to_string(int(100 * options.min_valid_fraction)) +
                " %): too little texture, out of the disparity range, or occluded";
    return r;
  }
  r.disparity_px = Median(d);
  r.disparity16 = Median(d16);
  // Scatter about a least-squares plane d = a + b x + c y (a tilted surface is not noise).
  Eigen::MatrixXd A(r.num_valid, 3);
  Eigen::VectorXd b(r.num_valid);
  const double x0 = r.roi.x + (r.roi.width - 1) / 2.0, y0 = r.roi.y + (r.roi.height - 1) / 2.0;
  for (int i = 0; i < r.num_valid; ++i) {
    A(i, 0) = 1;
    A(i, 1) = xyd[i].x() - x0;
    A(i, 2) = xyd[i].y() - y0;
    b(i) = xyd[i].z();
  }
  const Eigen::Vector3d plane = A.colPivHouseholderQr().solve(b);
  std::vector<double> res(r.num_valid);
  for (int i = 0; i < r.num_valid; ++i) res[i] = b(i) - A.row(i).dot(plane);
  const double med = Median(res);
  for (double& v : res) v = std::abs(v - med);
  r.scatter_px = 1.4826 * Median(res);
  const double n_eff = std::max(1.0, double(r.num_valid) / (options.sgbm.block_size * options.sgbm.block_size));
  r.sigma_disparity_px = std::hypot(1.2533 * r.scatter_px / std::sqrt(n_eff), options.subpixel_floor_px);
  // Depth at the ROI centre with the median disparity, through the raw cameras.
  const cv::Point2d left(x0, y0), right(x0 - r.disparity_px, y0);
  const RectifiedTriangulation tri = TriangulateRectified(rig, rect, left, right);
  if (!tri.ok) {
    r.message = tri.message;
    return r;
  }
  r.depth_m = tri.depth_m;
  r.sigma_match_m = r.depth_m / r.disparity_px * r.sigma_disparity_px;
  r.sigma_calib_m = tri.sigma_calib_m;
  r.sigma_m = std::isfinite(r.sigma_calib_m) ? std::hypot(r.sigma_calib_m, r.sigma_match_m) : r.sigma_match_m;
  r.ok = true;
  return r;
}

cv::Mat RectifyTruthDepth(const fitting::Rectification& rect, const cv::Mat& depth_z_raw_left) {
  if (depth_z_raw_left.type() != CV_32F || depth_z_raw_left.size() != rect.size)
    throw std::invalid_argument("RectifyTruthDepth: truth depth must be CV_32F of the calibration's image size");
  cv::Mat raw_z;
  cv::remap(depth_z_raw_left,
            raw_z,
            rect.map_x[0],
            rect.map_y[0],
            cv::INTER_NEAREST,
            cv::BORDER_CONSTANT,
            cv::Scalar(std::numeric_limits<double>::quiet_NaN()));
  // A rectified pixel's ray r_rect = ((x - cx) / f, (y - cy) / f, 1) is R1^T r_rect in the raw
  // camera, so a point at rectified depth Z has raw z = Z (R1^T r_rect)_z.
  cv::Mat out(rect.size, CV_32F);
  const cv::Matx33d Rt = rect.R1.t();
  const double f = rect.P1(0, 0), cx = rect.P1(0, 2), cy = rect.P1(1, 2);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const float zr = raw_z.at<float>(y, x);
      const double k = Rt(2, 0) * (x - cx) / f + Rt(2, 1) * (y - cy) / f + Rt(2, 2);
      out.at<float>(y, x) = std::isfinite(zr) && k > 1e-6 ? float(zr / k) : std::numeric_limits<float>::quiet_NaN();
    }
  return out;
}

cv::Mat ColourDisparity(const DepthMaps& maps, const SgbmOptions& sgbm) {
  cv::Mat grey(maps.disparity_px.size(), CV_8U), mask(maps.disparity_px.size(), CV_8U);
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x) {
      const float d = maps.disparity_px.at<float>(y, x);
      mask.at<uint8_t>(y, x) = std::isfinite(d) ? 255 : 0;
      const double t = std::isfinite(d) ? (d - sgbm.min_disparity) / sgbm.num_disparities : 0;
      grey.at<uint8_t>(y, x) = uint8_t(std::clamp(255.0 * t, 0.0, 255.0));
    }
  cv::Mat colour, out(grey.size(), CV_8UC3, cv::Scalar::all(0));
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.copyTo(out, mask);
  return out;
}

cv::Mat ColourDepth(const cv::Mat& depth_m, double near_m, double far_m) {
  cv::Mat grey(depth_m.size(), CV_8U), mask(depth_m.size(), CV_8U);
  for (int y = 0; y < grey.rows; ++y)
    for (int x = 0; x < grey.cols; ++x) {
      const float z = depth_m.at<float>(y, x);
      mask.at<uint8_t>(y, x) = std::isfinite(z) ? 255 : 0;
      const double t = std::isfinite(z) ? (far_m - z) / std::max(1e-9, far_m - near_m) : 0;
      grey.at<uint8_t>(y, x) = uint8_t(std::clamp(255.0 * t, 0.0, 255.0));
    }
  cv::Mat colour, out(grey.size(), CV_8UC3, cv::Scalar::all(0));
  cv::applyColorMap(grey, colour, cv::COLORMAP_TURBO);
  colour.copyTo(out, mask);
  return out;
}

cv::Mat DepthMillimetres16(const cv::Mat& depth_m) {
  cv::Mat out(depth_m.size(), CV_16U);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      const float z = depth_m.at<float>(y, x);
      out.at<uint16_t>(y, x) = std::isfinite(z) && z > 0 ? uint16_t(std::min(65535.0, std::round(1000.0 * z))) : 0;
    }
  return out;
}

DisparityConstantFit FitDisparityConstant(const std::vector<double>& disparity16,
                                          const std::vector<double>& true_m,
                                          double focal_px,
                                          double baseline_m) {
  if (disparity16.size() != true_m.size()) throw std::invalid_argument("FitDisparityConstant: size mismatch");
  DisparityConstantFit f;
  f.k_calibration = 16 * focal_px * baseline_m;
  std::vector<double> products;
  for (size_t i = 0; i < true_m.size(); ++i)
    if (disparity16[i] > 0 && std::isfinite(disparity16[i]) && true_m[i] > 0)
      products.push_back(disparity16[i] * true_m[i]);
  f.num_rows = int(products.size());
  f.estimate_m.assign(true_m.size(), kNaN);
  f.loo_estimate_m.assign(true_m.size(), kNaN);
  if (products.empty()) return f;
  double sum = 0, sum2 = 0;
  for (double p : products) sum += p, sum2 += p * p;
  const double n = double(products.size());
  f.k_disp16_m = sum / n;
  f.k_cv_pct = n > 1 ? 100 * std::sqrt(std::max(0.0, (sum2 - sum * sum / n) / (n - 1))) / f.k_disp16_m : 0;
  double abs_sum = 0, loo_sum = 0;
  int loo_n = 0;
  for (size_t i = 0; i < true_m.size(); ++i) {
    if (!(disparity16[i] > 0 && std::isfinite(disparity16[i]) && true_m[i] > 0)) continue;
    f.estimate_m[i] = f.k_disp16_m / disparity16[i];
    const double e = 100 * std::abs(f.estimate_m[i] - true_m[i]) / true_m[i];
    abs_sum += e;
    f.max_abs_pct = std::max(f.max_abs_pct, e);
    if (n > 1) {
      const double k_loo = (sum - disparity16[i] * true_m[i]) / (n - 1);
      f.loo_estimate_m[i] = k_loo / disparity16[i];
      loo_sum += 100 * std::abs(f.loo_estimate_m[i] - true_m[i]) / true_m[i];
      ++loo_n;
    }
  }
  f.mean_abs_pct = abs_sum / n;
  f.loo_mean_abs_pct = loo_n ? loo_sum / loo_n : kNaN;
  return f;
}

}  // namespace owlcal::evaluation
