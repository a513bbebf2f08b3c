// Camera model: one typed suite for both distortion models (the suite every model runs): round trips,
// limit cases, autodiff vs numeric Jacobians, double/Jet agreement. The comparison with
// cv::projectPoints lives in tests/robot/camera_model_opencv_test.cc (this folder's tests do
// not link OpenCV).
#include "models/camera_model.h"

#include <gtest/gtest.h>

#include <random>

#include <ceres/autodiff_cost_function.h>

#include "tests/models/model_test_util.h"

namespace owlcal::models {
namespace {

// Random but physically sensible parameters: f 560-700 px (real Owls: 578-635), centre near
// the middle of a 640x480 image, distortion as strong as real fits but still invertible over
// the whole image (d r_d / d r > 0 out to the corners).
template <typename Camera>
std::vector<double> RandomParams(std::mt19937& rng) {
  std::uniform_real_distribution<double> f(560, 700), c(-20, 20), k1(-0.15, 0.05), k2(-0.01, 0.08), p(-2e-3, 2e-3),
      k3(-0.01, 0.01), rat(-0.02, 0.02);
  const double fx = f(rng);
  std::vector<double> v = {
      fx, fx * (1 + 0.01 * c(rng) / 20), 319.5 + c(rng), 239.5 + c(rng), k1(rng), k2(rng), p(rng), p(rng), k3(rng)};
  if constexpr (Camera::kNumDistortion == 8) {
    // Rational model: k4..k6 with k4 close to k1 as in real fits, so the ratio stays tame.
    v.push_back(v[4] + rat(rng));
    v.push_back(rat(rng));
    v.push_back(rat(rng));
  }
  return v;
}

Eigen::Vector3d RandomPoint(std::mt19937& rng) {
  std::uniform_real_distribution<double> xy(-0.45, 0.45), z(0.2, 5.0);
  const double depth = z(rng);
  return Eigen::Vector3d(xy(rng) * depth, xy(rng) * depth * 0.8, depth);
}

template <typename Camera>
class CameraModelTest : public ::testing::Test {};
using CameraTypes = ::testing::Types<Camera5, Camera8>;
TYPED_TEST_SUITE(CameraModelTest, CameraTypes);

TYPED_TEST(CameraModelTest, WithoutDistortionIsThePinhole) {
  std::vector<double> p(TypeParam::kNumParams, 0.0);
  p[0] = 600;
  p[1] = 590;
  p[2] = 320;
  p[3] = 240;
  const double x[3] = {0.1, -0.2, 2.0};
  double pix[2];
  ASSERT_TRUE(TypeParam::Project(p.data(), x, pix));
  EXPECT_DOUBLE_EQ(pix[0], 320 + 600 * 0.05);
  EXPECT_DOUBLE_EQ(pix[1], 240 - 590 * 0.1);
}

TYPED_TEST(CameraModelTest, PointsBehindOrOnThePlaneAreRejected) {
  std::mt19937 rng(1);
  const std::vector<double> p = RandomParams<TypeParam>(rng);
  double pix[2];
  for (double z : {0.0, -1.0, 1e-12}) {
    const double x[3] = {0.1, 0.1, z};
    EXPECT_FALSE(TypeParam::Project(p.data(), x, pix)) << z;
  }
}

TYPED_TEST(CameraModelTest, UnprojectRoundTripInsideTheImage) {
  std::mt19937 rng(2);
  double worst = 0;
  for (int trial = 0; trial < 50; ++trial) {
    const std::vector<double> p = RandomParams<TypeParam>(rng);
    for (int v = 0; v <= 480; v += 40) {
      for (int u = 0; u <= 640; u += 40) {
        const double pixel[2] = {u - 0.5, v - 0.5};  // the image's outer corners included
        double ray[3], back[2];
        ASSERT_TRUE(TypeParam::Unproject(p.data(), pixel, ray)) << "trial " << trial << " at " << u << "," << v;
        ASSERT_TRUE(TypeParam::Project(p.data(), ray, back));
        worst = std::max(worst, std::hypot(back[0] - pixel[0], back[1] - pixel[1]));
      }
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TYPED_TEST(CameraModelTest, ProjectThenUnprojectRecoversTheRay) {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const std::vector<double> p = RandomParams<TypeParam>(rng);
    const Eigen::Vector3d x = RandomPoint(rng);
    double pix[2], ray[3];
    ASSERT_TRUE(TypeParam::Project(p.data(), x.data(), pix));
    ASSERT_TRUE(TypeParam::Unproject(p.data(), pix, ray));
    EXPECT_NEAR(ray[0], x.x() / x.z(), 1e-9);
    EXPECT_NEAR(ray[1], x.y() / x.z(), 1e-9);
    EXPECT_EQ(ray[2], 1.0);
  }
}

template <typename Camera>
struct ProjectCost {
  template <typename T>
  bool operator()(const T* params, const T* point, T* pixel) const {
    return Camera::Project(params, point, pixel);
  }
};

TYPED_TEST(CameraModelTest, AutodiffJacobiansMatchNumeric) {
  std::mt19937 rng(4);
  ceres::AutoDiffCostFunction<ProjectCost<TypeParam>, 2, TypeParam::kNumParams, 3> cost(new ProjectCost<TypeParam>);
  for (int trial = 0; trial < 30; ++trial) {
    const std::vector<double> p = RandomParams<TypeParam>(rng);
    const Eigen::Vector3d x = RandomPoint(rng);
    EXPECT_EQ(testing::GradientCheck(cost, {p.data(), x.data()}), "") << "trial " << trial;
  }
}

TYPED_TEST(CameraModelTest, DoubleAndJetAgree) {
  using J = ceres::Jet<double, 3>;
  std::mt19937 rng(5);
  for (int trial = 0; trial < 100; ++trial) {
    const std::vector<double> p = RandomParams<TypeParam>(rng);
    const Eigen::Vector3d x = RandomPoint(rng);
    double pix[2];
    ASSERT_TRUE(TypeParam::Project(p.data(), x.data(), pix));
    std::vector<J> pj(p.begin(), p.end());
    J xj[3] = {J(x.x(), 0), J(x.y(), 1), J(x.z(), 2)};
    J pixj[2];
    ASSERT_TRUE(TypeParam::Project(pj.data(), xj, pixj));
    EXPECT_NEAR(pixj[0].a, pix[0], 1e-12);
    EXPECT_NEAR(pixj[1].a, pix[1], 1e-12);
    // The derivative along the viewing ray is zero: scaling the point keeps the pixel.
    const double along = pixj[0].v.dot(x) / x.norm();
    EXPECT_NEAR(along, 0.0, 1e-9);
  }
}

TEST(CameraIntrinsics, DispatchesToTheConfiguredModel) {
  CameraIntrinsics c5, c8;
  c5.params = {500, 500, 320, 240, -0.2, 0.05, 0.001, -0.001, 0.01};
  c8.model = DistortionModel::kOpenCv8;
  c8.params = {500, 500, 320, 240, -0.2, 0.05, 0.001, -0.001, 0.01, 0.1, 0, 0};
  const double x[3] = {0.3, 0.2, 1.0};
  double a[2], b[2], r5[2], r8[2];
  ASSERT_TRUE(c5.Project(x, a));
  ASSERT_TRUE(Camera5::Project(c5.params.data(), x, r5));
  ASSERT_TRUE(c8.Project(x, b));
  ASSERT_TRUE(Camera8::Project(c8.params.data(), x, r8));
  EXPECT_EQ(a[0], r5[0]);
  EXPECT_EQ(b[0], r8[0]);
  EXPECT_NE(a[0], b[0]);  // k4 = 0.1 changes the projection
  EXPECT_EQ(c5.NumDistortion(), 5);
  EXPECT_EQ(c8.NumDistortion(), 8);
  EXPECT_EQ(c8.Distortion().size(), 8u);
  const int n = VisitCameraModel(DistortionModel::kOpenCv8, []<typename Cam>() { return Cam::kNumParams; });
  EXPECT_EQ(n, 12);
}

}  // namespace
}  // namespace owlcal::models
