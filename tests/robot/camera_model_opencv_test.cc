// models::OpenCvCamera against cv::projectPoints (equal to 1e-9 px over
// random points and parameters, 5 and 8 coefficients). It lives under tests/robot/ because
// that test folder links OpenCV and tests/models/ does not.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "models/camera_model.h"

namespace owlcal::models {
namespace {

template <typename Camera>
double WorstDifferenceFromOpenCv(uint32_t seed, int num_trials, int num_points) {
  std::mt19937 rng(seed);
  // Wide parameter ranges on purpose: equality must hold for any values, not only sane ones.
  std::uniform_real_distribution<double> f(300, 900), c(250, 400), k(-0.5, 0.5), p(-0.01, 0.01), xy(-0.6, 0.6),
      z(0.1, 10);
  double worst = 0;
  for (int trial = 0; trial < num_trials; ++trial) {
    std::vector<double> params = {
        f(rng), f(rng), c(rng), c(rng) - 80, k(rng), k(rng) * 0.5, p(rng), p(rng), k(rng) * 0.2};
    if constexpr (Camera::kNumDistortion == 8) {
      params.push_back(k(rng));
      params.push_back(k(rng) * 0.5);
      params.push_back(k(rng) * 0.2);
    }
    const cv::Matx33d camera_matrix(params[0], 0, params[2], 0, params[1], params[3], 0, 0, 1);
    const std::vector<double> dist(params.begin() + 4, params.end());
    std::vector<cv::Point3d> points;
    for (int i = 0; i < num_points; ++i) {
      const double depth = z(rng);
      points.emplace_back(xy(rng) * depth, xy(rng) * depth, depth);
    }
    std::vector<cv::Point2d> expected;
    cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_matrix, dist, expected);
    for (int i = 0; i < num_points; ++i) {
      const double x[3] = {points[i].x, points[i].y, points[i].z};
      double pix[2] = {0, 0};
      EXPECT_TRUE(Camera::Project(params.data(), x, pix));
      worst = std::max(worst, std::hypot(pix[0] - expected[i].x, pix[1] - expected[i].y));
    }
  }
  return worst;
}

TEST(CameraModelVsOpenCv, FiveCoefficientsEqualProjectPoints) {
  const double worst = WorstDifferenceFromOpenCv<Camera5>(11, 200, 50);
  EXPECT_LT(worst, 1e-9);
  RecordProperty("worst_px", std::to_string(worst));
}

TEST(CameraModelVsOpenCv, EightCoefficientsEqualProjectPoints) {
  const double worst = WorstDifferenceFromOpenCv<Camera8>(12, 200, 50);
  EXPECT_LT(worst, 1e-9);
  RecordProperty("worst_px", std::to_string(worst));
}

TEST(CameraModelVsOpenCv, DifferentParametersDoDiffer) {
  // Guards the comparison itself: a wrong k1 must show up far above 1e-9 px.
  const double params[9] = {585, 585, 320, 240, -0.2, 0.05, 0.001, 0.001, 0.01};
  const std::vector<cv::Point3d> pts = {{0.3, 0.2, 1.0}};
  std::vector<cv::Point2d> out;
  cv::projectPoints(pts,
                    cv::Vec3d(0, 0, 0),
                    cv::Vec3d(0, 0, 0),
                    cv::Matx33d(585, 0, 320, 0, 585, 240, 0, 0, 1),
                    std::vector<double>{-0.21, 0.05, 0.001, 0.001, 0.01},
                    out);
  const double x[3] = {0.3, 0.2, 1.0};
  double pix[2];
  ASSERT_TRUE(Camera5::Project(params, x, pix));
  EXPECT_GT(std::abs(pix[0] - out[0].x), 1e-3);
}

}  // namespace
}  // namespace owlcal::models
