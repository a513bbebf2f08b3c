// The edge-blur measure recovers the Gaussian blur a synthetic camera put on a scene of dark
// blocks at random angles (not a chessboard: the measure must work on any scene with edges),
// through noise and JPEG; the Laplacian variance falls with blur; bad regions are refused with
// a reason.
#include "calib/edge_sharpness.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

// 320x240: twelve dark rectangles (30-70 px sides, any angle) on a light ground, pixel-
// integrated (8x supersampled, area-averaged), blurred by a Gaussian of `blur` px, with
// Gaussian noise of `noise` grey levels.
cv::Mat Blocks(double blur, double noise, uint64_t seed) {
  const int s = 8, w = 320, h = 240;
  cv::Mat hi(h * s, w * s, CV_8U, cv::Scalar(190));
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  for (int k = 0; k < 12; ++k) {
    const cv::RotatedRect r(cv::Point2f(float((30 + 260 * u(rng)) * s), float((30 + 180 * u(rng)) * s)),
                            cv::Size2f(float((30 + 40 * u(rng)) * s), float((30 + 40 * u(rng)) * s)),
                            float(180 * u(rng)));
    cv::Point2f p[4];
    r.points(p);
    std::vector<cv::Point> poly(p, p + 4);
    cv::fillConvexPoly(hi, poly, cv::Scalar(50), cv::LINE_8);
  }
  cv::Mat f;
  hi.convertTo(f, CV_32F);
  cv::Mat img;
  cv::resize(f, img, cv::Size(w, h), 0, 0, cv::INTER_AREA);
  if (blur > 0) cv::GaussianBlur(img, img, cv::Size(0, 0), blur);
  cv::Mat n(img.size(), CV_32F);
  cv::RNG r(seed);
  r.fill(n, cv::RNG::NORMAL, 0, noise);
  img += n;
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

TEST(EdgeSharpness, RecoversTheGaussianBlurOfAnyScene) {
  const cv::Rect all(0, 0, 320, 240);
  double last_lap = 1e9;
  for (const double blur : {0.7, 1.0, 1.5, 2.2}) {
    const cv::Mat img = Blocks(blur, 1.5, 11);
    const EdgeSharpness s = MeasureEdgeSharpness(img, all);
    ASSERT_TRUE(s.ok) << s.reason;
    // The pixel's own box adds 1/12 px^2 to the Gaussian's variance.
    const double expected = std::sqrt(blur * blur + 1.0 / 12);
    EXPECT_NEAR(s.blur_sigma_px, expected, 0.08 * expected) << "blur " << blur;
    EXPECT_GT(s.num_edges, 100) << "blur " << blur;
    EXPECT_LT(s.blur_sigma_se_px, 0.05) << "blur " << blur;
    EXPECT_NEAR(s.contrast, 140, 8) << "blur " << blur;
    EXPECT_LT(s.laplacian_variance, last_lap) << "blur " << blur;
    last_lap = s.laplacian_variance;
  }
}

TEST(EdgeSharpness, JpegAtTheOwlsQualityMovesTheBlurLittle) {
  const cv::Mat img = Blocks(1.2, 1.5, 5);
  std::vector<unsigned char> bytes;
  cv::imencode(".jpg", img, bytes, {cv::IMWRITE_JPEG_QUALITY, 85});
  const cv::Mat jpeg = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  const EdgeSharpness raw = MeasureEdgeSharpness(img, {0, 0, 320, 240});
  const EdgeSharpness coded = MeasureEdgeSharpness(jpeg, {0, 0, 320, 240});
  ASSERT_TRUE(raw.ok && coded.ok) << raw.reason << coded.reason;
  EXPECT_NEAR(coded.blur_sigma_px, raw.blur_sigma_px, 0.1 * raw.blur_sigma_px);
}

TEST(EdgeSharpness, RefusesRegionsItCannotMeasure) {
  const cv::Mat flat(240, 320, CV_8U, cv::Scalar(128));
  EdgeSharpness s = MeasureEdgeSharpness(flat, {0, 0, 320, 240});
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.reason.find("no edges"), std::string::npos) << s.reason;

  s = MeasureEdgeSharpness(Blocks(1, 1, 3), {310, 230, 40, 40});  // clipped to 10x10
  EXPECT_FALSE(s.ok);
  EXPECT_EQ(s.roi, cv::Rect(310, 230, 10, 10));
  EXPECT_NE(s.reason.find("too small"), std::string::npos) << s.reason;

  // Pure noise has gradients but no isolated steps.
  cv::Mat noise(240, 320, CV_8U);
  cv::RNG(9).fill(noise, cv::RNG::UNIFORM, 0, 256);
  s = MeasureEdgeSharpness(noise, {0, 0, 320, 240});
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.reason.find("too few isolated edges"), std::string::npos) << s.reason;

  EdgeSharpnessOptions bad;
  bad.probe_px = 1;
  s = MeasureEdgeSharpness(Blocks(1, 1, 3), {0, 0, 320, 240}, bad);
  EXPECT_FALSE(s.ok);
  EXPECT_NE(s.reason.find("probe_px"), std::string::npos) << s.reason;
}

}  // namespace
}  // namespace owlcal::calib
