// The default virtual Owl streams like a real Owl: mirrored, so a course-style
// client that flips the whole 1280x480 frame (Owl_basic.cpp: cv::flip(Frame, FrameFlpd, 1);
// Left = cols 0-639, Right = cols 640-1279) sees the left eye on the left, the right way round,
// and owlcal's default robot file (models::DefaultRobotConfig) reads the same halves.
//
// The check is geometric: a black disc placed to the robot's left is found in each half by the
// difference between a frame with and without it, and its centroid must sit where the truth's
// camera of THAT eye projects it (a mirrored view puts it at 639 - x, the other eye 50 px away).
#include <cmath>
#include <optional>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "robot/mjpeg_client.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {
namespace {

// What the course's Owl_basic.cpp does with a frame of the stream.
struct CourseView {
  cv::Mat left, right;
};
CourseView CourseClientView(const std::vector<uint8_t>& jpeg) {
  const cv::Mat frame = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(frame.cols, 1280);
  cv::Mat flipped;
  cv::flip(frame, flipped, 1);
  return {flipped(cv::Rect(0, 0, 640, 480)).clone(), flipped(cv::Rect(640, 0, 640, 480)).clone()};
}

// Centroid of the pixels that changed by more than 30 grey levels between a and b.
std::optional<cv::Point2d> ChangeCentroid(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff, mask;
  cv::absdiff(a, b, diff);
  cv::threshold(diff, mask, 30, 255, cv::THRESH_BINARY);
  const cv::Moments m = cv::moments(mask, true);
  if (m.m00 < 20) return std::nullopt;
  return cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
}

struct Observed {
  CourseView without, with;
  std::vector<uint8_t> jpeg_with;
  cv::Point2d predicted[2];  // [kLeftEye], [kRightEye] from the truth
};

// Streams two frames at the centre pose: every target hidden, then the fixation disc shown
// 15 cm to the robot's left at 0.8 m. Virtual clock, no noise: deterministic.
Observed Observe(VirtualOwlOptions o) {
  o.noise_sigma = 0;
  o.drop_probability = 0;
  VirtualOwl owl(o);
  owl.SendServos(owl.Config().Centre());
  owl.SleepNs(1'000'000'000);
  for (const std::string& name : owl.TargetNames()) owl.SetTargetVisible(name, false);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(-0.15, 0.0, 0.8);
  owl.SetTargetPose("fixation", pose);
  Observed r;
  const auto a = owl.GrabFrame(owl.NowNs(), 1'000'000'000);
  EXPECT_TRUE(a.has_value());
  owl.SetTargetVisible("fixation", true);
  const auto b = owl.GrabFrame(a->stamp_ns, 1'000'000'000);
  EXPECT_TRUE(b.has_value());
  r.without = CourseClientView(a->jpeg);
  r.with = CourseClientView(b->jpeg);
  r.jpeg_with = b->jpeg;
  const FrameTruth ft = owl.TruthForFrame(b->seq);
  for (int eye : {int(models::kLeftEye), int(models::kRightEye)}) {
    const Eigen::Vector3d p = ft.cam_from_base[eye] * pose.translation();
    double px[2] = {-1, -1};
    EXPECT_TRUE(owl.Truth().intrinsics[eye].Project(p.data(), px));
    r.predicted[eye] = {px[0], px[1]};
  }
  return r;
}

TEST(StreamLayout, DefaultStreamIsMirroredAndACourseClientThatFlipsSeesEachEyeRightWayRound) {
  const Observed r = Observe({});
  const auto left = ChangeCentroid(r.without.left, r.with.left);
  const auto right = ChangeCentroid(r.without.right, r.with.right);
  ASSERT_TRUE(left && right);
  std::printf(
      "disc in the course client's Left (%.1f, %.1f), truth left eye (%.1f, %.1f); Right (%.1f, %.1f), truth "
      "right eye (%.1f, %.1f)\n",
      left->x,
      left->y,
      r.predicted[models::kLeftEye].x,
      r.predicted[models::kLeftEye].y,
      right->x,
      right->y,
      r.predicted[models::kRightEye].x,
      r.predicted[models::kRightEye].y);
  // The truth places the disc left of centre in both eyes, the left eye seeing it further right
  // (positive disparity, 17 px), so mirroring (~280 px) or swapping (17 px) would move it far beyond 3 px.
  ASSERT_LT(r.predicted[models::kLeftEye].x, 290);
  ASSERT_GT(r.predicted[models::kLeftEye].x - r.predicted[models::kRightEye].x, 10);
  EXPECT_NEAR(left->x, r.predicted[models::kLeftEye].x, 3.0);
  EXPECT_NEAR(left->y, r.predicted[models::kLeftEye].y, 3.0);
  EXPECT_NEAR(right->x, r.predicted[models::kRightEye].x, 3.0);
  EXPECT_NEAR(right->y, r.predicted[models::kRightEye].y, 3.0);
}

TEST(StreamLayout, OwlcalsDefaultRobotFileReadsTheSameHalvesAsTheCourseClient) {
  const Observed r = Observe({});
  const models::RobotConfig robot = models::DefaultRobotConfig();
  EXPECT_TRUE(robot.mirror_stream);
  EXPECT_FALSE(robot.swap_eyes);
  cv::Mat left, right;
  robot::SplitStereo(
      cv::imdecode(r.jpeg_with, cv::IMREAD_GRAYSCALE), robot.mirror_stream, robot.swap_eyes, &left, &right);
  EXPECT_EQ(cv::norm(left, r.with.left, cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(right, r.with.right, cv::NORM_INF), 0);
}

TEST(StreamLayout, NoMirrorShowsTheCourseClientTheRightEyeMirroredInItsLeftWindow) {
  // `owlcal sim --no-mirror`: what the issue saw with the old default.
  VirtualOwlOptions o;
  RobotTruth t = DefaultRobotTruth();
  t.robot.mirror_stream = false;
  o.truth = t;
  const Observed r = Observe(o);
  const auto left = ChangeCentroid(r.without.left, r.with.left);
  ASSERT_TRUE(left.has_value());
  EXPECT_NEAR(left->x, 639.0 - r.predicted[models::kRightEye].x, 3.0);
  EXPECT_GT(std::abs(left->x - r.predicted[models::kLeftEye].x), 100);
}

TEST(StreamLayout, SwapPutsTheLeftEyeInTheRightHalfAfterTheFlip) {
  VirtualOwlOptions o;
  RobotTruth t = DefaultRobotTruth();
  t.robot.swap_eyes = true;
  o.truth = t;
  const Observed r = Observe(o);
  const auto right = ChangeCentroid(r.without.right, r.with.right);
  ASSERT_TRUE(right.has_value());
  EXPECT_NEAR(right->x, r.predicted[models::kLeftEye].x, 3.0);
}

}  // namespace
}  // namespace owlcal::sim
