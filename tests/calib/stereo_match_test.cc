#include "calib/stereo_match.h"

#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

// A smooth random texture (blurred noise), 8-bit.
cv::Mat Texture(int w, int h, unsigned seed) {
  cv::Mat n(h, w, CV_32F);
  cv::RNG rng(seed);
  rng.fill(n, cv::RNG::NORMAL, 128, 60);
  cv::GaussianBlur(n, n, cv::Size(0, 0), 1.5);
  cv::Mat out;
  n.convertTo(out, CV_8U, 2.0, -128);
  return out;
}

// The right image sees the scene shifted left by `d` px (and down by dy).
cv::Mat Shift(const cv::Mat& img, double d, double dy) {
  cv::Mat out;
  const cv::Mat M = (cv::Mat_<double>(2, 3) << 1, 0, -d, 0, 1, dy);
  cv::warpAffine(img, out, M, img.size(), cv::INTER_CUBIC, cv::BORDER_REFLECT);
  return out;
}

TEST(StereoMatch, RecoversSubPixelDisparityOfShiftedTexture) {
  const cv::Mat left = Texture(640, 480, 3);
  for (double d : {12.0, 37.3, 80.55, 130.8}) {
    const cv::Mat right = Shift(left, d, 0.4);
    StereoMatchOptions o;
    const StereoMatch m = MatchAlongRow(left, right, o);
    ASSERT_TRUE(m.found) << m.message;
    EXPECT_NEAR(m.disparity_px, d, 0.12) << "d=" << d;
    EXPECT_NEAR(m.dy_px, 0.4, 0.15);
    EXPECT_GT(m.ncc, 0.95);
    EXPECT_GT(m.sigma_disparity_px, 0.0);
    EXPECT_LT(m.sigma_disparity_px, 0.3);
  }
}

TEST(StereoMatch, MatchingSigmaGrowsWithNoise) {
  const cv::Mat left = Texture(640, 480, 5);
  const cv::Mat right = Shift(left, 40.25, 0);
  cv::Mat noisy_l = left.clone(), noisy_r = right.clone();
  cv::Mat n(left.size(), CV_16S);
  cv::RNG rng(9);
  rng.fill(n, cv::RNG::NORMAL, 0, 8);
  cv::add(left, n, noisy_l, cv::noArray(), CV_8U);
  rng.fill(n, cv::RNG::NORMAL, 0, 8);
  cv::add(right, n, noisy_r, cv::noArray(), CV_8U);
  StereoMatchOptions o;
  const StereoMatch clean = MatchAlongRow(left, right, o);
  const StereoMatch noisy = MatchAlongRow(noisy_l, noisy_r, o);
  ASSERT_TRUE(clean.found && noisy.found);
  EXPECT_GT(noisy.noise_sigma, 4 * clean.noise_sigma + 1.0);
  EXPECT_GT(noisy.sigma_disparity_px, clean.sigma_disparity_px);
  EXPECT_NEAR(noisy.disparity_px, 40.25, 5 * noisy.sigma_disparity_px);
}

TEST(StereoMatch, FlatImageIsNotFoundAndRoiIsHonoured) {
  const cv::Mat flat(480, 640, CV_8U, cv::Scalar(100));
  StereoMatchOptions o;
  EXPECT_FALSE(MatchAlongRow(flat, flat, o).found);
  const cv::Mat left = Texture(640, 480, 11);
  o.template_roi = cv::Rect(400, 100, 40, 30);
  const StereoMatch m = MatchAlongRow(left, Shift(left, 22.5, 0), o);
  ASSERT_TRUE(m.found);
  EXPECT_NEAR(m.left_px.x, 400 + 19.5, 1e-9);
  EXPECT_NEAR(m.left_px.y, 100 + 14.5, 1e-9);
  EXPECT_NEAR(m.right_px.x, 400 + 19.5 - 22.5, 0.12);
  o.template_roi = cv::Rect(630, 100, 40, 30);
  EXPECT_FALSE(MatchAlongRow(left, left, o).found);
}

TEST(StereoMatch, ParabolaPeakOffsetIsExactForAParabola) {
  auto f = [](double x) { return 1.0 - (x - 0.3) * (x - 0.3); };
  EXPECT_NEAR(ParabolaPeakOffset(f(-1), f(0), f(1)), 0.3, 1e-12);
  EXPECT_EQ(ParabolaPeakOffset(1, 0, 1), 0.0);
}

}  // namespace
}  // namespace owlcal::calib
