// The Lucas-Kanade tracker follows a point through sub-pixel and multi-pixel shifts of a textured
// image to within a few hundredths of a pixel (its refinement against the first frame keeps the
// error from growing with the number of frames), and loses the track with a reason, never a stale
// position, when the point leaves the image or an occluder covers it.
#include "calib/lk_tracker.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

// 640x480 grey: smoothed random texture (blobs of a few px) with a dark disc of radius 8 px on a
// light card at (320, 240).
cv::Mat Scene(uint64_t seed) {
  cv::Mat noise(480, 640, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  cv::Mat img = 128 + 120 * noise;
  cv::rectangle(img, cv::Rect(300, 220, 41, 41), cv::Scalar(230), cv::FILLED);
  cv::circle(img, cv::Point(320 * 16, 240 * 16), 8 * 16, cv::Scalar(30), cv::FILLED, cv::LINE_AA, 4);
  cv::Mat out;
  img.convertTo(out, CV_8U);
  return out;
}

// The scene moved by (dx, dy) px (bilinear).
cv::Mat Shifted(const cv::Mat& img, double dx, double dy) {
  cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::Mat out;
  cv::warpAffine(img, out, m, img.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return out;
}

TEST(LkTracker, FollowsTheDiscThroughAFigureOfEightWithinHundredthsOfAPixel) {
  const cv::Mat scene = Scene(3);
  LkTracker lk;
  std::string why;
  ASSERT_TRUE(lk.Start(scene, Eigen::Vector2d(320, 240), &why)) << why;
  double max_err = 0, sum2 = 0;
  const int n = 60;
  for (int k = 1; k <= n; ++k) {
    const double t = 2 * M_PI * k / n;
    const Eigen::Vector2d shift(40 * std::sin(t), 20 * std::sin(2 * t));  // up to 4.2 px per frame
    const LkUpdate u = lk.Track(Shifted(scene, shift.x(), shift.y()));
    ASSERT_TRUE(u.ok) << "frame " << k << ": " << u.reason;
    const double err = (u.px - (Eigen::Vector2d(320, 240) + shift)).norm();
    max_err = std::max(max_err, err);
    sum2 += err * err;
    EXPECT_GE(u.fb_error_px, 0);
    EXPECT_GT(u.ncc, 0.9);
  }
  std::cout << "LK on a shifted texture: RMS " << std::sqrt(sum2 / n) << " px, max " << max_err << " px\n";
  EXPECT_LT(std::sqrt(sum2 / n), 0.05);
  EXPECT_LT(max_err, 0.1);
}

TEST(LkTracker, LosesTheTrackWithAReasonWhenThePointLeavesTheImage) {
  const cv::Mat scene = Scene(5);
  LkTracker lk;
  std::string why;
  ASSERT_TRUE(lk.Start(scene, Eigen::Vector2d(320, 240), &why)) << why;
  LkUpdate u;
  int k = 0;
  for (; k < 60; ++k) {
    u = lk.Track(Shifted(scene, 6.0 * (k + 1), 0));  // 6 px per frame to the right, out at 640
    if (!u.ok) break;
  }
  ASSERT_FALSE(u.ok);
  EXPECT_FALSE(u.reason.empty());
  EXPECT_FALSE(lk.tracking());
  // Lost while the point was near the right border: no frame past the image gave a position.
  EXPECT_GT(320 + 6.0 * (k + 1), 640 - 1 - LkTrackerOptions{}.window_px / 2 - 6) << u.reason;
  EXPECT_LE(lk.position().x(), 640 - 1 - LkTrackerOptions{}.window_px / 2)
      << "the last good position lay inside the image";
  // Later frames say lost too, with the reason.
  const LkUpdate later = lk.Track(scene);
  EXPECT_FALSE(later.ok);
  EXPECT_NE(later.reason.find("lost earlier"), std::string::npos) << later.reason;
}

TEST(LkTracker, LosesTheTrackWhenAnOccluderCoversTheTarget) {
  const cv::Mat scene = Scene(7);
  LkTracker lk;
  std::string why;
  ASSERT_TRUE(lk.Start(scene, Eigen::Vector2d(320, 240), &why)) << why;
  ASSERT_TRUE(lk.Track(Shifted(scene, 1.5, 0.5)).ok);
  cv::Mat occluded = Shifted(scene, 3, 1);
  cv::rectangle(occluded, cv::Rect(290, 200, 70, 80), cv::Scalar(90), cv::FILLED);  // a flat grey card
  const LkUpdate u = lk.Track(occluded);
  EXPECT_FALSE(u.ok);
  EXPECT_FALSE(u.reason.empty());
  std::cout << "occluded: " << u.reason << "\n";
}

TEST(LkTracker, RefusesToStartOnAFlatPatchOrAtTheBorder) {
  const cv::Mat flat(480, 640, CV_8U, cv::Scalar(128));
  LkTracker lk;
  std::string why;
  EXPECT_FALSE(lk.Start(flat, Eigen::Vector2d(320, 240), &why));
  EXPECT_NE(why.find("no texture"), std::string::npos) << why;
  EXPECT_FALSE(lk.Start(Scene(1), Eigen::Vector2d(5, 240), &why));
  EXPECT_NE(why.find("border"), std::string::npos) << why;
  LkTrackerOptions bad;
  bad.window_px = 20;
  EXPECT_FALSE(bad.Check(&why));
}

TEST(LkTracker, ResumeKeepsTheFirstReference) {
  const cv::Mat scene = Scene(9);
  LkTracker lk;
  std::string why;
  EXPECT_FALSE(lk.Resume(scene, Eigen::Vector2d(320, 240), &why));  // never started
  ASSERT_TRUE(lk.Start(scene, Eigen::Vector2d(320, 240), &why)) << why;
  lk.Stop("test");
  // A detector puts the target 0.6 px off on a moved frame; the refinement against the first
  // look corrects it.
  const cv::Mat moved = Shifted(scene, 12.25, -7.5);
  ASSERT_TRUE(lk.Resume(moved, Eigen::Vector2d(320 + 12.25 + 0.6, 240 - 7.5), &why)) << why;
  EXPECT_LT((lk.position() - Eigen::Vector2d(332.25, 232.5)).norm(), 0.05);
  const LkUpdate u = lk.Track(Shifted(scene, 14, -6));
  ASSERT_TRUE(u.ok) << u.reason;
  EXPECT_LT((u.px - Eigen::Vector2d(334, 234)).norm(), 0.05);
}

}  // namespace
}  // namespace owlcal::calib
