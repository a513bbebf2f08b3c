// The salience map picks what stands out: a dark disc on a light card in front of a textured wall
// (the virtual Owl's fixation target), a saturated colour blob on a grey scene (the colour
// channel), and ranks the candidates with inhibition of return (no two within its radius).
#include "calib/salience.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

namespace owlcal::calib {
namespace {

// A BGR 640x480 grey wall of smoothed random texture (contrast like the virtual Owl's).
cv::Mat Wall(uint64_t seed) {
  cv::Mat noise(480, 640, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, 1);
  cv::GaussianBlur(noise, noise, cv::Size(0, 0), 2.0);
  cv::Mat img = 140 + 60 * noise;
  cv::Mat g, bgr;
  img.convertTo(g, CV_8U);
  cv::cvtColor(g, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

TEST(Salience, TopCandidateIsTheDiscOnItsCard) {
  cv::Mat img = Wall(11);
  cv::rectangle(img, cv::Rect(400 - 15, 180 - 15, 31, 31), cv::Scalar(235, 235, 235), cv::FILLED);
  cv::circle(img, cv::Point(400, 180), 8, cv::Scalar(25, 25, 25), cv::FILLED, cv::LINE_AA);
  const SalienceMap m = ComputeSalience(img, {});
  ASSERT_FALSE(m.candidates.empty());
  const SalienceCandidate& top = m.candidates[0];
  std::cout << "top " << top.px.transpose() << " score " << top.score << " (I " << top.intensity << " C " << top.colour
            << " O " << top.orientation << ")\n";
  EXPECT_LE(std::abs(top.px.x() - 400), 16);
  EXPECT_LE(std::abs(top.px.y() - 180), 16);
  EXPECT_EQ(top.colour, 0);  // a grey scene has no colour feature
  EXPECT_EQ(m.map.cols, 320);
  EXPECT_DOUBLE_EQ(m.scale, 2);
  // Ranked, and inhibition of return keeps candidates apart.
  for (size_t i = 1; i < m.candidates.size(); ++i) {
    EXPECT_LE(m.candidates[i].score, m.candidates[i - 1].score);
    for (size_t j = 0; j < i; ++j) EXPECT_GT((m.candidates[i].px - m.candidates[j].px).norm(), 40 - 2.5);
  }
}

TEST(Salience, ColourChannelFindsASaturatedBlob) {
  cv::Mat img(480, 640, CV_8UC3, cv::Scalar(128, 128, 128));
  // A red blob of the same grey level as the ground: only colour tells it apart.
  cv::circle(img, cv::Point(150, 330), 12, cv::Scalar(90, 90, 230), cv::FILLED, cv::LINE_AA);
  SalienceOptions o;
  o.num_candidates = 3;
  const SalienceMap m = ComputeSalience(img, o);
  ASSERT_FALSE(m.candidates.empty());
  EXPECT_LT((m.candidates[0].px - Eigen::Vector2d(150, 330)).norm(), 6);
  EXPECT_GT(m.candidates[0].colour, 0.5);
}

TEST(Salience, RefusesBadOptionsAndEmptyImages) {
  SalienceOptions o;
  o.dog_outer_px = 5;
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_THROW(ComputeSalience(cv::Mat(), {}), std::invalid_argument);
  EXPECT_THROW(ComputeSalience(Wall(1), o), std::invalid_argument);
  // A flat image has nothing salient: no candidate.
  EXPECT_TRUE(ComputeSalience(cv::Mat(480, 640, CV_8UC3, cv::Scalar(100, 100, 100)), {}).candidates.empty());
}

}  // namespace
}  // namespace owlcal::calib
