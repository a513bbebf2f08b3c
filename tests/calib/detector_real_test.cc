// The chessboard detection every command uses (calib/detector.h: classic, then sb) on the
// repository's real Owl sets: it finds boards that the fast check of the former
// calibrate-images path gave up on (blurred, low-contrast views of kit2020-chessboard), falls
// back to the sector-based detector where the classic one fails (darvill2019 session 2,
// left7), accepts the board turned by 90 deg, and says what it tried when nothing is found.
#include <algorithm>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/detector.h"
#include "tests/shared_data.h"

namespace owlcal::calib {
namespace {

using ::owlcal::test_data::SharedData;

TargetDefinition KitBoard(int cols = 9, int rows = 6) {
  TargetDefinition t;
  t.cols = cols;
  t.rows = rows;
  t.square_m = 0.026;
  return t;
}

cv::Mat Read(const std::string& relative) {
  const std::string path = SharedData() + "/owl-real/" + relative;
  cv::Mat m = cv::imread(path, cv::IMREAD_COLOR);
  EXPECT_FALSE(m.empty()) << path;
  return m;
}

// A washed-out, out-of-focus view: Gaussian blur (sigma 2.5 px), contrast 0.4 about mid-grey.
cv::Mat Degraded(const cv::Mat& image) {
  cv::Mat b;
  cv::GaussianBlur(image, b, cv::Size(0, 0), 2.5);
  b.convertTo(b, -1, 0.4, 128 * 0.6);
  return b;
}

// The options calibrate-images used before one detection path: classic with the fast check.
DetectorOptions FormerCalibrateImagesOptions() {
  DetectorOptions o;
  o.fast_check = true;
  return o;
}

TEST(DetectorReal, FindsBlurredLowContrastBoardsTheFastCheckGaveUpOn) {
  int former = 0, now = 0, tried = 0;
  for (int pair : {1, 4, 8, 10, 13, 16, 19, 22})
    for (const char* eye : {"left", "right"}) {
      const std::string name = "kit2020-chessboard/" + std::string(eye) + std::to_string(pair) + ".jpg";
      const cv::Mat original = Read(name);
      const cv::Mat img = Degraded(original);
      ++tried;
      former += DetectTarget(img, KitBoard(), FormerCalibrateImagesOptions()).found;
      const TargetDetection d = DetectTarget(img, KitBoard(), DetectorOptions());
      ASSERT_TRUE(d.found) << name << ": " << d.message;
      ASSERT_EQ(d.pixels.size(), 54u) << name;
      now += 1;
      // The same corners as on the sharp original (within 3 px: the blur and another detector).
      const TargetDetection sharp = DetectTarget(original, KitBoard(), DetectorOptions());
      ASSERT_TRUE(sharp.found) << name;
      double worst = 0;
      for (size_t i = 0; i < d.pixels.size(); ++i) worst = std::max(worst, (d.pixels[i] - sharp.pixels[i]).norm());
      EXPECT_LT(worst, 3.0) << name << " (" << d.detector << ")";
    }
  std::cout << "degraded kit2020 views: the former calibrate-images path found " << former << " of " << tried
            << ", the one path " << now << "\n";
  EXPECT_LE(former, tried / 2);
  EXPECT_EQ(now, tried);
}

TEST(DetectorReal, FallsBackToTheSectorBasedDetectorWhereClassicFails) {
  const cv::Mat img = Read("darvill2019-chessboard/session2/left7.jpg");
  DetectorOptions classic;
  classic.chessboard_method = ChessboardMethod::kClassic;
  const TargetDetection c = DetectTarget(img, KitBoard(), classic);
  EXPECT_FALSE(c.found);
  EXPECT_NE(c.message.find("tried classic 9x6"), std::string::npos) << c.message;
  const TargetDetection d = DetectTarget(img, KitBoard(), DetectorOptions());
  ASSERT_TRUE(d.found) << d.message;
  EXPECT_EQ(d.detector, "sb 9x6");
  EXPECT_EQ(d.pixels.size(), 54u);
}

// A pair whose eyes were found by different detectors must share corner ids: sb's corner k is
// classic's corner k on every kit2020 image where both find the board.
TEST(DetectorReal, ClassicAndSectorBasedNumberTheCornersAlike) {
  DetectorOptions classic, sb;
  classic.chessboard_method = ChessboardMethod::kClassic;
  sb.chessboard_method = ChessboardMethod::kSectorBased;
  int both = 0;
  for (int pair : {0, 1, 2, 3, 4, 5, 6, 8, 9, 10})
    for (const char* eye : {"left", "right"}) {
      const cv::Mat img = Read("kit2020-chessboard/" + std::string(eye) + std::to_string(pair) + ".jpg");
      const TargetDetection a = DetectTarget(img, KitBoard(), classic), b = DetectTarget(img, KitBoard(), sb);
      if (!a.found || !b.found) continue;
      ++both;
      double worst = 0;
      for (size_t i = 0; i < a.pixels.size(); ++i) worst = std::max(worst, (a.pixels[i] - b.pixels[i]).norm());
      EXPECT_LT(worst, 3.0) << eye << pair;
    }
  EXPECT_GE(both, 8);
}

TEST(DetectorReal, AcceptsTheBoardTurnedByNinetyDegrees) {
  const cv::Mat img = Read("kit2020-chessboard/left0.jpg");
  const TargetDetection wide = DetectTarget(img, KitBoard(9, 6), DetectorOptions());
  const TargetDetection tall = DetectTarget(img, KitBoard(6, 9), DetectorOptions());
  ASSERT_TRUE(wide.found) << wide.message;
  ASSERT_TRUE(tall.found) << tall.message;
  EXPECT_EQ(tall.pixels.size(), 54u);
  // The same 54 image points, ordered on the other grid.
  double worst = 0;
  for (const auto& p : tall.pixels) {
    double nearest = 1e9;
    for (const auto& q : wide.pixels) nearest = std::min(nearest, (p - q).norm());
    worst = std::max(worst, nearest);
  }
  EXPECT_LT(worst, 0.5);
}

TEST(DetectorReal, ANotFoundMessageListsTheDetectorsAndSizesTried) {
  const cv::Mat img = Read("darvill2019-chessboard/session1/left2.jpg");  // washed out against a window
  const TargetDetection d = DetectTarget(img, KitBoard(), DetectorOptions());
  ASSERT_FALSE(d.found);
  EXPECT_NE(d.message.find("chessboard 9x6 not found; tried classic 9x6, sb 9x6"), std::string::npos) << d.message;
  EXPECT_NE(d.message.find("6x9"), std::string::npos) << d.message;
  const TargetDetection f = DetectTarget(img, KitBoard(), FormerCalibrateImagesOptions());
  EXPECT_NE(f.message.find("fast check"), std::string::npos) << f.message;
}

}  // namespace
}  // namespace owlcal::calib
