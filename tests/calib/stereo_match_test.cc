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
    EXPECT_EQ(m.confidence, MatchConfidence::kOk) << m.message;
    EXPECT_LT(m.lr_error_px, 0.3);
    EXPECT_LT(m.peak_ratio, 0.85);
    EXPECT_EQ(m.blocks_used, 4);
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

// Vertical stripes repeating every 24 px: every period matches as well as the true one.
TEST(StereoMatch, RepeatedTextureIsAmbiguousNeverOk) {
  cv::Mat left(480, 640, CV_8U);
  for (int y = 0; y < 480; ++y)
    for (int x = 0; x < 640; ++x)
      left.at<uint8_t>(y, x) = static_cast<uint8_t>(128 + 90 * std::sin(2 * M_PI * x / 24.0));
  const StereoMatch m = MatchAlongRow(left, Shift(left, 30.4, 0), StereoMatchOptions());
  EXPECT_NE(m.confidence, MatchConfidence::kOk) << m.message;
  EXPECT_GT(m.peak_ratio, 0.85);
  EXPECT_NE(m.message.find("peak"), std::string::npos) << m.message;
}

// A near object (disparity 45) in front of a far background (disparity 12): a template astride
// its edge matches partly both; its quarters disagree.
TEST(StereoMatch, TemplateAcrossADepthEdgeIsLowConfidence) {
  const cv::Mat far = Texture(640, 480, 21), near = Texture(640, 480, 22);
  cv::Mat left = far.clone(), right = Shift(far, 12, 0);
  const cv::Rect object(320, 150, 200, 180);  // in the left image
  near(object).copyTo(left(object));
  near(object).copyTo(right(object - cv::Point(45, 0)));
  StereoMatchOptions o;
  o.template_roi = cv::Rect(object.x - 32, 200, 64, 48);  // half background, half object
  const StereoMatch m = MatchAlongRow(left, right, o);
  EXPECT_NE(m.confidence, MatchConfidence::kOk) << m.message;
  EXPECT_FALSE(m.flags.empty());
  // Wholly on the object: confident, at the object's disparity.
  o.template_roi = cv::Rect(object.x + 40, 200, 64, 48);
  const StereoMatch on = MatchAlongRow(left, right, o);
  EXPECT_EQ(on.confidence, MatchConfidence::kOk) << on.message;
  EXPECT_NEAR(on.disparity_px, 45, 0.2);
}

// The right image of another scene: nothing matches; never ok.
TEST(StereoMatch, UnrelatedImagesFail) {
  const StereoMatch m = MatchAlongRow(Texture(640, 480, 31), Texture(640, 480, 32), StereoMatchOptions());
  EXPECT_EQ(m.confidence, MatchConfidence::kFailed) << m.message;
  EXPECT_FALSE(m.found);
}

TEST(StereoMatch, ParabolaPeakOffsetIsExactForAParabola) {
  auto f = [](double x) { return 1.0 - (x - 0.3) * (x - 0.3); };
  EXPECT_NEAR(ParabolaPeakOffset(f(-1), f(0), f(1)), 0.3, 1e-12);
  EXPECT_EQ(ParabolaPeakOffset(1, 0, 1), 0.0);
}

}  // namespace
}  // namespace owlcal::calib
