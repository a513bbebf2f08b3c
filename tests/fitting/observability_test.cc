#include "fitting/observability.h"

#include <cmath>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

namespace owlcal::fitting {
namespace observability_test {

TEST(Observability, FullRankIsTheInverseWithNothingUndetermined) {
  Eigen::MatrixXd h(2, 2);
  h << 4.0, 1.0, 1.0, 9.0;
  const Observability o = AnalyseInformation(h, {"a", "b"}, kDefaultRankTolerance);
  ASSERT_TRUE(o.ok);
  EXPECT_EQ(o.null_dimension, 0);
  EXPECT_TRUE(o.determined[0] && o.determined[1]);
  EXPECT_TRUE(o.covariance.isApprox(h.inverse(), 1e-12));
  EXPECT_GT(o.reciprocal_condition, 0.5);
}

TEST(Observability, CoupledParametersAreNamedAndTheRestKeepsItsSigma) {
  // a and b only appear as a + b; c is measured alone with information 4.
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(3, 3);
  h.topLeftCorner(2, 2) << 1.0, 1.0, 1.0, 1.0;
  h(2, 2) = 4.0;
  const Observability o = AnalyseInformation(h, {"cam.a", "cam.b", "ext.c"}, kDefaultRankTolerance);
  ASSERT_TRUE(o.ok);
  EXPECT_EQ(o.null_dimension, 1);
  EXPECT_FALSE(o.determined[0]);
  EXPECT_FALSE(o.determined[1]);
  EXPECT_NE(o.reasons[0].find("cannot separate it from cam.b"), std::string::npos) << o.reasons[0];
  EXPECT_NE(o.reasons[1].find("cam.a"), std::string::npos) << o.reasons[1];
  EXPECT_NE(o.reasons[0].find("null space"), std::string::npos);
  ASSERT_TRUE(o.determined[2]);
  EXPECT_NEAR(o.covariance(2, 2), 0.25, 1e-12);
  EXPECT_TRUE(std::isnan(o.covariance(0, 0)));
  EXPECT_TRUE(std::isnan(o.covariance(0, 2)));
}

TEST(Observability, ZeroInformationIsUnconstrained) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(2, 2);
  h(0, 0) = 2.0;
  const Observability o = AnalyseInformation(h, {"a", "b"}, kDefaultRankTolerance);
  EXPECT_TRUE(o.determined[0]);
  EXPECT_FALSE(o.determined[1]);
  EXPECT_NE(o.reasons[1].find("no observation constrains it"), std::string::npos) << o.reasons[1];
  EXPECT_NEAR(o.covariance(0, 0), 0.5, 1e-12);
}

TEST(Observability, AWeakButNonZeroDirectionIsKeptBelowTheTolerance) {
  // Eigenvalues of the unit-diagonal matrix: 1 +- 0.999999 -> ratio 5e-7, above 1e-12.
  Eigen::MatrixXd h(2, 2);
  h << 1.0, 0.999999, 0.999999, 1.0;
  const Observability o = AnalyseInformation(h, {"a", "b"}, kDefaultRankTolerance);
  EXPECT_EQ(o.null_dimension, 0);
  EXPECT_TRUE(o.determined[0] && o.determined[1]);
  EXPECT_TRUE(o.covariance.isApprox(h.inverse(), 1e-6));
  // A looser tolerance calls the same direction a null space.
  const Observability loose = AnalyseInformation(h, {"a", "b"}, 1e-5);
  EXPECT_EQ(loose.null_dimension, 1);
  EXPECT_FALSE(loose.determined[0]);
}

// r = (g0 + g1 * x + l_k - y) / sigma: the offset g0 and each group's local offset l_k cannot
// be told apart, the slope g1 can.
struct LineResidual {
  double x, y, sigma;
  template <typename T>
  bool operator()(const T* g, const T* l, T* r) const {
    r[0] = (g[0] + g[1] * x + l[0] - y) / sigma;
    return true;
  }
};

TEST(Observability, LocalBlocksAreEliminatedFromAProblem) {
  double g[2] = {0.5, 2.0};
  double l[3][1] = {{0.1}, {-0.2}, {0.3}};
  ceres::Problem problem;
  for (int k = 0; k < 3; ++k)
    for (int i = 0; i < 5; ++i)
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<LineResidual, 1, 2, 1>(new LineResidual{double(i), 1.0, 0.1}),
          nullptr,
          g,
          l[k]);
  const Observability o =
      AnalyseObservability(&problem, {g}, {l[0], l[1], l[2]}, {"line.offset", "line.slope"}, kDefaultRankTolerance);
  ASSERT_TRUE(o.ok) << o.message;
  EXPECT_FALSE(o.determined[0]);
  EXPECT_NE(o.reasons[0].find("cannot separate it from the board poses"), std::string::npos) << o.reasons[0];
  ASSERT_TRUE(o.determined[1]);
  // Slope of 15 points, x = 0..4 in three groups with free offsets: var = sigma^2 / (3 sum (x - mean)^2).
  EXPECT_NEAR(o.covariance(1, 1), 0.01 / (3 * 10.0), 1e-12);
  // Names that do not match the tangent size are refused, not misapplied.
  EXPECT_FALSE(AnalyseObservability(&problem, {g}, {l[0]}, {"only.one"}, kDefaultRankTolerance).ok);
}

}  // namespace observability_test
}  // namespace owlcal::fitting
