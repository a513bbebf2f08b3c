// Photometric statistics of a chessboard image recover what a synthetic camera put in: levels,
// noise, Gaussian edge blur; JPEG quality and block artefacts are read back from encoded files.
#include "calib/chessboard_image_stats.h"

#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

TargetDefinition Board() {
  TargetDefinition t;
  t.cols = 9;
  t.rows = 6;
  t.square_m = 0.026;
  return t;
}

// A 9x6 inner-corner board (10 x 7 squares of 36 px, turned by 4 deg) on a mid-grey
// background, pixel-integrated (8x supersampled, area-averaged), black `black`, white
// `white`, then blurred by a Gaussian of blur_sigma px and given Gaussian noise.
cv::Mat SyntheticBoard(double black, double white, double blur_sigma, double noise_sigma, uint64_t seed) {
  const int s = 8, w = 640, h = 480;
  cv::Mat hi(h * s, w * s, CV_32F, cv::Scalar(0.5 * (black + white)));
  const double a = 4 * M_PI / 180, sq = 36.0 * s, x0 = 140.0 * s, y0 = 110.0 * s;
  for (int y = 0; y < hi.rows; ++y) {
    float* p = hi.ptr<float>(y);
    for (int x = 0; x < hi.cols; ++x) {
      const double dx = x + 0.5 - x0, dy = y + 0.5 - y0;
      const double u = (std::cos(a) * dx + std::sin(a) * dy) / sq, v = (-std::sin(a) * dx + std::cos(a) * dy) / sq;
      if (u < 0 || v < 0 || u >= 10 || v >= 7) continue;
      p[x] = float(((int(u) + int(v)) % 2) ? white : black);
    }
  }
  cv::Mat img;
  cv::resize(hi, img, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  if (blur_sigma > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), blur_sigma);
  cv::Mat noise(img.size(), CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, noise_sigma);
  img += noise;
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

TEST(ChessboardImageStats, RecoversLevelsNoiseAndBlurOfASyntheticCamera) {
  for (const double blur : {0.8, 1.5}) {
    const cv::Mat img = SyntheticBoard(60, 160, blur, 2.0, 7);
    const TargetDetection d = DetectTarget(img, Board(), {});
    ASSERT_TRUE(d.found) << d.message;
    const ChessboardImageStats s = MeasureChessboardImage(img, d, Board());
    ASSERT_TRUE(s.ok) << s.message;
    EXPECT_NEAR(s.white_level, 160, 2);
    EXPECT_NEAR(s.black_level, 60, 2);
    // Integer rounding adds 1/12 grey^2 of variance.
    EXPECT_NEAR(s.noise_white, std::sqrt(4 + 1.0 / 12), 0.25) << "blur " << blur;
    EXPECT_NEAR(s.noise_black, std::sqrt(4 + 1.0 / 12), 0.25) << "blur " << blur;
    // The pixel's own box adds 1/12 px^2 to the Gaussian's variance.
    EXPECT_NEAR(s.edge_sigma_px, std::sqrt(blur * blur + 1.0 / 12), 0.1) << "blur " << blur;
    EXPECT_GT(s.num_edges, 80);
    EXPECT_EQ(s.saturated_fraction, 0);
    EXPECT_NEAR(s.board_area_fraction, 40.0 * 36 * 36 / (640 * 480), 0.01);  // 8 x 5 squares between inner corners
  }
}

TEST(ChessboardImageStats, NeedsTheWholeBoard) {
  const cv::Mat img = SyntheticBoard(60, 160, 1, 1, 3);
  TargetDetection d = DetectTarget(img, Board(), {});
  ASSERT_TRUE(d.found);
  d.pixels.pop_back();
  d.corner_ids.pop_back();
  const ChessboardImageStats s = MeasureChessboardImage(img, d, Board());
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.message.find("54 corners"), std::string::npos) << s.message;
}

TEST(ChessboardImageStats, JpegQualityAndBlockinessAreReadBack) {
  const cv::Mat img = SyntheticBoard(60, 160, 1, 2, 5);
  for (const int q : {40, 75, 95}) {
    std::vector<unsigned char> bytes;
    cv::imencode(".jpg", img, bytes, {cv::IMWRITE_JPEG_QUALITY, q});
    EXPECT_EQ(JpegQualityEstimate(bytes), q);
  }
  EXPECT_EQ(JpegQualityEstimate({0x89, 'P', 'N', 'G'}), -1);
  std::vector<unsigned char> low;
  cv::imencode(".jpg", img, low, {cv::IMWRITE_JPEG_QUALITY, 15});
  const double raw = JpegBlockiness(img), blocky = JpegBlockiness(cv::imdecode(low, cv::IMREAD_GRAYSCALE));
  EXPECT_NEAR(raw, 1.0, 0.05);
  EXPECT_GT(blocky, raw + 0.3);
}

}  // namespace
}  // namespace owlcal::calib
