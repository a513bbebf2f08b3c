#include "calib/image_pairs.h"

#include <cstdlib>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "owlcal_version.h"
#include "tests/shared_data.h"

namespace owlcal::calib {
namespace {

namespace fs = std::filesystem;

using ::owlcal::test_data::SharedData;

TEST(ImagePairs, ListsKitChessboardPairsInNaturalOrderWithoutPairSeven) {
  const auto list = ListImagePairs(SharedData() + "/owl-real/kit2020-chessboard", {});
  ASSERT_EQ(list.pairs.size(), 27u);
  EXPECT_EQ(list.pairs[0].key, "0");
  EXPECT_EQ(list.pairs[7].key, "8");  // there is no pair 7
  EXPECT_EQ(list.pairs.back().key, "27");
  EXPECT_TRUE(list.unpaired.empty());
  const auto d = ListImagePairs(SharedData() + "/owl-real/kit2020-distance-target1", {});
  ASSERT_EQ(d.pairs.size(), 13u);
  EXPECT_EQ(d.pairs[0].key, "30cm");
  EXPECT_EQ(d.pairs.back().key, "150cm");
}

// A synthetic frame whose halves are marked: left half dark with a bright dot near its
// left edge, right half bright.
cv::Mat MarkedFrame() {
  cv::Mat f(48, 128, CV_8UC3, cv::Scalar(0, 0, 0));
  f(cv::Rect(64, 0, 64, 48)).setTo(cv::Scalar(200, 200, 200));
  cv::circle(f, {5, 24}, 3, cv::Scalar(255, 255, 255), -1);
  return f;
}

TEST(ImagePairs, SideBySideMirrorAndSwapFollowTheDocumentedConventions) {
  const fs::path dir = fs::path(::testing::TempDir()) / "owlcal_sbs_test";
  fs::create_directories(dir);
  cv::imwrite((dir / "frame1.png").string(), MarkedFrame());
  ImagePairOptions o;
  o.side_by_side = true;
  const auto list = ListImagePairs(dir.string(), o);
  ASSERT_EQ(list.pairs.size(), 1u);
  cv::Mat l, r;
  LoadImagePair(list.pairs[0], o, &l, &r);
  ASSERT_EQ(l.cols, 64);
  EXPECT_LT(cv::mean(l)[0], 50);  // left = columns 0-63 (dark)
  EXPECT_GT(cv::mean(r)[0], 150);
  EXPECT_GT(l.at<cv::Vec3b>(24, 5)[0], 200);  // dot not flipped
  o.mirror = true;                            // whole frame flipped: left = former right half (bright)
  LoadImagePair(list.pairs[0], o, &l, &r);
  EXPECT_GT(cv::mean(l)[0], 150);
  EXPECT_LT(cv::mean(r)[0], 50);
  EXPECT_GT(r.at<cv::Vec3b>(24, 63 - 5)[0], 200);  // dot mirrored
  o.swap = true;
  LoadImagePair(list.pairs[0], o, &l, &r);
  EXPECT_LT(cv::mean(l)[0], 50);
}

// Regression: two 10000x10000 pairs took 106 s and 1.2 GB in calibrate-images, with no cap. An
// image over ImagePairOptions::max_pixels (kMaxImagePixels by default) is refused, naming the file.
TEST(ImagePairs, AnImageOverThePixelLimitIsRefusedNamingIt) {
  const fs::path dir = fs::path(::testing::TempDir()) / "owlcal_pixel_cap_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::imwrite((dir / "left1.png").string(), cv::Mat(100, 120, CV_8UC3, cv::Scalar(90, 90, 90)));
  cv::imwrite((dir / "right1.png").string(), cv::Mat(100, 120, CV_8UC3, cv::Scalar(90, 90, 90)));
  ImagePairOptions o;
  const auto list = ListImagePairs(dir.string(), o);
  ASSERT_EQ(list.pairs.size(), 1u);
  cv::Mat l, r;
  EXPECT_EQ(o.max_pixels, kMaxImagePixels);
  LoadImagePair(list.pairs[0], o, &l, &r);
  EXPECT_EQ(l.cols, 120);
  o.max_pixels = 11999;
  try {
    LoadImagePair(list.pairs[0], o, &l, &r);
    ADD_FAILURE() << "an image over the limit was read";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(list.pairs[0].left_path + ": image 120x100 (12000 pixels) is larger than the "
                                                                   "limit of 11999 pixels"),
              std::string::npos)
        << e.what();
  }
}

TEST(ImagePairs, SeparateFilesMirrorFlipsEachImageAndReportsUnpaired) {
  const fs::path dir = fs::path(::testing::TempDir()) / "owlcal_pairs_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  cv::Mat a(20, 30, CV_8UC3, cv::Scalar(0, 0, 0));
  a.at<cv::Vec3b>(10, 2) = cv::Vec3b(255, 255, 255);
  cv::imwrite((dir / "left2.png").string(), a);
  cv::imwrite((dir / "right2.png").string(), a);
  cv::imwrite((dir / "left10.png").string(), a);
  cv::imwrite((dir / "right10.png").string(), a);
  cv::imwrite((dir / "left3.png").string(), a);
  ImagePairOptions o;
  const auto list = ListImagePairs(dir.string(), o);
  ASSERT_EQ(list.pairs.size(), 2u);
  EXPECT_EQ(list.pairs[0].key, "2");
  EXPECT_EQ(list.pairs[1].key, "10");
  ASSERT_EQ(list.unpaired.size(), 1u);
  EXPECT_NE(list.unpaired[0].find("left3"), std::string::npos);
  o.mirror = true;
  cv::Mat l, r;
  LoadImagePair(list.pairs[0], o, &l, &r);
  EXPECT_EQ(l.at<cv::Vec3b>(10, 27)[0], 255);
  EXPECT_EQ(r.at<cv::Vec3b>(10, 27)[0], 255);
  EXPECT_THROW(ListImagePairs((dir / "nope").string(), o), std::runtime_error);
}

}  // namespace
}  // namespace owlcal::calib
