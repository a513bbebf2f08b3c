// fitting/observability.h ClusterRobustCovariance: the sandwich covariance over clusters of
// residual blocks, checked by Monte Carlo on a line fit whose errors are shared within clusters
// (as a detector bias is shared by the corners of one view), with local blocks profiled out.
#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <vector>

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "fitting/observability.h"

namespace owlcal::fitting {
namespace {

// y = a + b x + d_g, whitened by sigma; d_g a local offset per group g (groups cross the clusters).
struct LineResidual {
  double x, y, sigma;
  template <typename T>
  bool operator()(const T* ab, const T* d, T* r) const {
    r[0] = (ab[0] + ab[1] * x + d[0] - y) / sigma;
    return true;
  }
};

struct Fit {
  double a = 0, sigma_model = 0, sigma_robust = 0;
};

// One data set: num_clusters clusters of `per_cluster` points, each cluster's points sharing
// an error u ~ N(0, shared); white noise N(0, white) on top. Whitened by `white` (the fit's
// measured noise). Four local offsets, point j of every cluster in group j % 4.
Fit FitOnce(std::mt19937_64* rng, int num_clusters, int per_cluster, double shared, double white) {
  std::normal_distribution<double> n01(0, 1);
  std::uniform_real_distribution<double> ux(-1, 1);
  double ab[2] = {0, 0};
  double d[4] = {0, 0, 0, 0};
  const double truth_d[4] = {0.3, -0.2, 0.1, 0.0};
  ceres::Problem problem;
  std::map<ceres::ResidualBlockId, int> cluster;
  for (int c = 0; c < num_clusters; ++c) {
    const double u = shared * n01(*rng);
    const double xc = ux(*rng);
    for (int j = 0; j < per_cluster; ++j) {
      const double x = xc + 0.2 * ux(*rng);
      const double y = 1.0 + 2.0 * x + truth_d[j % 4] + u + white * n01(*rng);
      auto* f = new ceres::AutoDiffCostFunction<LineResidual, 1, 2, 1>(new LineResidual{x, y, white});
      cluster[problem.AddResidualBlock(f, nullptr, ab, &d[j % 4])] = c;
    }
  }
  problem.SetParameterBlockConstant(&d[3]);  // the gauge: a and the offsets share a constant
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  const Observability o = AnalyseObservability(&problem, {ab}, {&d[0], &d[1], &d[2], &d[3]}, {"a", "b"}, 1e-12);
  const ClusterRobust r = ClusterRobustCovariance(
      &problem,
      {ab},
      {&d[0], &d[1], &d[2], &d[3]},
      [&](ceres::ResidualBlockId id) { return cluster.at(id); },
      o.covariance);
  EXPECT_TRUE(o.ok && r.ok) << r.message;
  EXPECT_EQ(r.num_clusters, num_clusters);
  return {ab[0] - 1.0, std::sqrt(o.covariance(0, 0)), std::sqrt(r.covariance(0, 0))};
}

struct Scores {
  double rms_z_model = 0, rms_z_robust = 0, mean_ratio = 0;  // ratio: robust sigma / model sigma
};

Scores Repeat(int reps, int num_clusters, int per_cluster, double shared, double white) {
  std::mt19937_64 rng(20261127);
  Scores s;
  for (int i = 0; i < reps; ++i) {
    const Fit f = FitOnce(&rng, num_clusters, per_cluster, shared, white);
    s.rms_z_model += std::pow(f.a / f.sigma_model, 2);
    s.rms_z_robust += std::pow(f.a / f.sigma_robust, 2);
    s.mean_ratio += f.sigma_robust / f.sigma_model;
  }
  s.rms_z_model = std::sqrt(s.rms_z_model / reps);
  s.rms_z_robust = std::sqrt(s.rms_z_robust / reps);
  s.mean_ratio /= reps;
  std::printf("%d clusters of %d, shared %.3f, white %.3f: RMS z %.3f (model) %.3f (sandwich), sigma ratio %.3f\n",
              num_clusters,
              per_cluster,
              shared,
              white,
              s.rms_z_model,
              s.rms_z_robust,
              s.mean_ratio);
  return s;
}

TEST(ClusterRobust, SharedErrorsWithinClustersWidenSigmaToTheScatter) {
  // 40 clusters of 12 points; the shared error (0.05) as large as the white noise (0.05): the
  // intercept's error is about twice what white noise predicts, and the model sigma misses it.
  const Scores s = Repeat(200, 40, 12, 0.05, 0.05);
  EXPECT_GT(s.rms_z_model, 1.8);
  EXPECT_NEAR(s.rms_z_robust, 1.0, 0.15);
  EXPECT_GT(s.mean_ratio, 1.7);
}

TEST(ClusterRobust, WhiteErrorsLeaveTheModelCovariance) {
  // With 40 clusters the sandwich is ~15 % short here (RMS z 1.16: residuals are smaller than
  // the errors, and it is estimated from 40 scores); the head fit has ~450 (one per view).
  const Scores s = Repeat(200, 160, 12, 0.0, 0.05);
  EXPECT_NEAR(s.rms_z_model, 1.0, 0.12);
  EXPECT_NEAR(s.rms_z_robust, 1.0, 0.15);
  EXPECT_NEAR(s.mean_ratio, 1.0, 0.1);
}

TEST(ClusterRobust, RaiseToFloorCoversBothAndKeepsWhatIsAlreadyAbove) {
  Eigen::MatrixXd c(2, 2), f(2, 2);
  c << 4.0, 0.0, 0.0, 1.0;
  f << 1.0, 0.0, 0.0, 2.0;
  RaiseToFloor(f, &c);
  EXPECT_NEAR(c(0, 0), 4.0, 1e-12);
  EXPECT_NEAR(c(1, 1), 2.0, 1e-12);
  EXPECT_NEAR(c(0, 1), 0.0, 1e-12);
  // Loewner order: c - f and c - old c positive semi-definite.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> e(c - f);
  EXPECT_GE(e.eigenvalues().minCoeff(), -1e-12);
}

}  // namespace
}  // namespace owlcal::fitting
