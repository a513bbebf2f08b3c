// Detectors on rendered targets whose corners are known exactly: pins libapriltag's corner
// order and pixel origin (docs/conventions.md, Pixels) and the chessboard corner accuracy.
#include "calib/detector.h"

#include <cstdlib>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
}

namespace owlcal::calib {
namespace detector_test {

// Renders `cells` (one source pixel per cell; cell i spans [i, i+1]) into a width x height
// image through H, which maps cell coordinates to image coordinates with (0,0) at the top-left
// pixel's CORNER. Supersampled by `s`, then INTER_AREA downsampled, so edges are exact.
cv::Mat Render(const cv::Mat& cells, const cv::Matx33d& H, int width, int height, int s = 8) {
  const cv::Matx33d A(1.0 / s, 0, 0.5 / s, 0, 1.0 / s, 0.5 / s, 0, 0, 1);  // hi-res centre -> corner conv
  const cv::Matx33d B(1, 0, -0.5, 0, 1, -0.5, 0, 0, 1);                    // cell corner -> centre conv
  const cv::Matx33d M = B * H.inv() * A;
  cv::Mat hi;
  cv::warpPerspective(cells,
                      hi,
                      cv::Mat(M),
                      cv::Size(width * s, height * s),
                      cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT,
                      cv::Scalar(255));
  cv::Mat out;
  cv::resize(hi, out, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  return out;
}

// Image position (OpenCV convention) of cell coordinate (u, v).
Eigen::Vector2d Expected(const cv::Matx33d& H, double u, double v) {
  const cv::Vec3d p = H * cv::Vec3d(u, v, 1);
  return Eigen::Vector2d(p[0] / p[2] - 0.5, p[1] / p[2] - 0.5);
}

cv::Matx33d TiltedHomography(double scale, double angle_deg, double cx, double cy, double persp) {
  const double a = angle_deg * M_PI / 180;
  return cv::Matx33d(scale * std::cos(a),
                     -scale * std::sin(a),
                     cx,
                     scale * std::sin(a),
                     scale * std::cos(a),
                     cy,
                     persp,
                     0.3 * persp,
                     1);
}

TEST(DetectorAprilTag, CornerOrderMatchesRenderedTag) {
  apriltag_family_t* tf = tag36h11_create();
  image_u8_t* im = apriltag_to_image(tf, 7);
  cv::Mat cells(im->height, im->width, CV_8U);
  for (int y = 0; y < im->height; ++y)
    for (int x = 0; x < im->width; ++x) cells.at<uint8_t>(y, x) = im->buf[y * im->stride + x];
  free(im->buf);  // image_u8_destroy is not exported by Debian's libapriltag
  free(im);
  tag36h11_destroy(tf);
  ASSERT_EQ(cells.cols, 10);  // tag36h11: 8x8 black-bordered tag + 1 white cell each side

  TargetDefinition t;
  t.kind = TargetKind::kAprilGrid;
  t.tag_cols = 1;
  t.tag_rows = 1;
  t.first_id = 7;
  for (double angle : {0.0, 25.0, -30.0}) {
    // Cell (u, v) -> image: 14 px per cell, rotated, mild perspective; tag centre at (5, 5).
    const cv::Matx33d H = TiltedHomography(14, angle, 0, 0, 0.0004) * cv::Matx33d(1, 0, -5, 0, 1, -5, 0, 0, 1);
    const cv::Matx33d Hc = cv::Matx33d(1, 0, 160, 0, 1, 120, 0, 0, 1) * H;
    const cv::Mat img = Render(cells, Hc, 320, 240);
    for (double decimate : {1.0, 2.0}) {
      DetectorOptions opt;
      opt.apriltag_decimate = decimate;
      const TargetDetection d = DetectTarget(img, t, opt);
      ASSERT_TRUE(d.found) << d.message << " angle " << angle;
      ASSERT_EQ(d.corner_ids.size(), 4u);
      // Black border spans cells 1..9: TL (1,1), TR (9,1), BR (9,9), BL (1,9).
      const Eigen::Vector2d expect[4] = {
          Expected(Hc, 1, 1), Expected(Hc, 9, 1), Expected(Hc, 9, 9), Expected(Hc, 1, 9)};
      for (int k = 0; k < 4; ++k) {
        EXPECT_EQ(d.corner_ids[k], 4 * 7 + k);
        EXPECT_LT((d.pixels[k] - expect[k]).norm(), 0.25)
            << "corner " << k << " angle " << angle << " decimate " << decimate << " got " << d.pixels[k].transpose()
            << " expected " << expect[k].transpose();
      }
    }
  }
}

TEST(DetectorAprilTag, TagOfAnotherGridIsIgnored) {
  apriltag_family_t* tf = tag36h11_create();
  image_u8_t* im = apriltag_to_image(tf, 40);
  cv::Mat cells(im->height, im->width, CV_8U);
  for (int y = 0; y < im->height; ++y)
    for (int x = 0; x < im->width; ++x) cells.at<uint8_t>(y, x) = im->buf[y * im->stride + x];
  free(im->buf);  // image_u8_destroy is not exported by Debian's libapriltag
  free(im);
  tag36h11_destroy(tf);
  const cv::Mat img = Render(cells, TiltedHomography(12, 10, 100, 60, 0), 320, 240);
  TargetDefinition t;
  t.kind = TargetKind::kAprilGrid;  // 6x6 grid, ids 0..35
  const TargetDetection d = DetectTarget(img, t, DetectorOptions());
  EXPECT_FALSE(d.found) << d.message;
}

// A 9x6 chessboard (10x7 squares) with a white margin: cells 12 x 9, inner corner (c, r) at
// cell coordinate (2 + c, 2 + r).
cv::Mat ChessCells() {
  cv::Mat cells(9, 12, CV_8U, cv::Scalar(255));
  for (int r = 0; r < 7; ++r)
    for (int c = 0; c < 10; ++c)
      if ((r + c) % 2 == 0) cells.at<uint8_t>(r + 1, c + 1) = 0;
  return cells;
}

double MaxCornerError(const TargetDetection& d, const cv::Matx33d& H, int cols) {
  // OpenCV may order the grid from either end; take the better of the two orders.
  double best = 1e9;
  for (bool reversed : {false, true}) {
    double worst = 0;
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      const int id = reversed ? int(d.pixels.size()) - 1 - d.corner_ids[i] : d.corner_ids[i];
      worst = std::max(worst, (d.pixels[i] - Expected(H, 2 + id % cols, 2 + id / cols)).norm());
    }
    best = std::min(best, worst);
  }
  return best;
}

TEST(DetectorChessboard, ClassicAndSbCornersWithinATenthOfAPixel) {
  TargetDefinition t;  // 9x6
  const cv::Matx33d H = TiltedHomography(40, 12, 100, 40, 0.0003);
  const cv::Mat img = Render(ChessCells(), H, 640, 480);
  for (ChessboardMethod m : {ChessboardMethod::kClassic, ChessboardMethod::kSectorBased}) {
    DetectorOptions opt;
    opt.chessboard_method = m;
    const TargetDetection d = DetectTarget(img, t, opt);
    ASSERT_TRUE(d.found) << d.message;
    ASSERT_EQ(d.pixels.size(), 54u);
    EXPECT_LT(MaxCornerError(d, H, 9), 0.1) << (m == ChessboardMethod::kClassic ? "classic" : "sb");
  }
}

TEST(DetectorChessboard, BlankImageIsNotFoundAndNamesTheBoard) {
  const cv::Mat blank(480, 640, CV_8U, cv::Scalar(128));
  DetectorOptions opt;
  opt.fast_check = true;
  const TargetDetection d = DetectTarget(blank, TargetDefinition(), opt);
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.message.find("9x6"), std::string::npos);
  EXPECT_TRUE(DetectionToObservations(d, TargetDefinition(), 0, 0).empty());
}

TEST(DetectorOptions, CheckNamesTheBadField) {
  DetectorOptions o;
  o.subpix_half_window = 0;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("subpix_half_window"), std::string::npos);
  EXPECT_THROW(DetectTarget(cv::Mat(10, 10, CV_8U), TargetDefinition(), o), std::invalid_argument);
  EXPECT_THROW(DetectTarget(cv::Mat(), TargetDefinition(), DetectorOptions()), std::invalid_argument);
}

TEST(SplitStereoFrame, MirrorAndSwapSelectHalves) {
  cv::Mat f(2, 4, CV_8U);
  for (int x = 0; x < 4; ++x) f.col(x).setTo(x);
  cv::Mat l, r;
  SplitStereoFrame(f, false, false, &l, &r);
  EXPECT_EQ(l.at<uint8_t>(0, 0), 0);
  EXPECT_EQ(r.at<uint8_t>(0, 0), 2);
  SplitStereoFrame(f, true, false, &l, &r);  // flipped: 3 2 | 1 0
  EXPECT_EQ(l.at<uint8_t>(0, 0), 3);
  EXPECT_EQ(r.at<uint8_t>(0, 1), 0);
  SplitStereoFrame(f, false, true, &l, &r);
  EXPECT_EQ(l.at<uint8_t>(0, 0), 2);
}

}  // namespace detector_test
}  // namespace owlcal::calib
