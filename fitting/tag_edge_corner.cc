#include "fitting/tag_edge_corner.h"

#include <cmath>
#include <vector>

#include <Eigen/Dense>
#include <Eigen/Eigenvalues>

namespace owlcal::fitting {

std::array<Eigen::Vector3d, 4> TagCornersOf(const Eigen::Vector3d& corner_in_target, int corner_id, double tag_size_m) {
  const double s = tag_size_m;
  const std::array<Eigen::Vector3d, 4> offset = {
      Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(s, 0, 0), Eigen::Vector3d(s, s, 0), Eigen::Vector3d(0, s, 0)};
  const int k = ((corner_id % 4) + 4) % 4;
  const Eigen::Vector3d top_left = corner_in_target - offset[k];
  std::array<Eigen::Vector3d, 4> out;
  for (int i = 0; i < 4; ++i) out[i] = top_left + offset[i];
  return out;
}

std::optional<Eigen::Vector2d> TagEdgeCornerPixel(
    const std::function<bool(const Eigen::Vector3d&, Eigen::Vector2d*)>& project,
    const std::array<Eigen::Vector3d, 4>& c,
    int k) {
  if (k < 0 || k > 3) return std::nullopt;
  // Corner k joins edge k-1 (corner k-1 to k) and edge k (corner k to k+1), as in the detector.
  const int edges[2] = {(k + 3) % 4, k};
  Eigen::Vector2d normal[2];
  double offset[2];
  constexpr int kSamples = 17;
  for (int j = 0; j < 2; ++j) {
    const Eigen::Vector3d& a = c[edges[j]];
    const Eigen::Vector3d& b = c[(edges[j] + 1) % 4];
    std::array<Eigen::Vector2d, kSamples> pts;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (int i = 0; i < kSamples; ++i) {
      if (!project(a + (0.1 + 0.8 * i / (kSamples - 1.0)) * (b - a), &pts[i])) return std::nullopt;
      mean += pts[i] / kSamples;
    }
    // Total least squares: the line's normal is the scatter matrix's smallest eigenvector.
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (const auto& p : pts) scatter += (p - mean) * (p - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(scatter);
    normal[j] = es.eigenvectors().col(0);
    offset[j] = normal[j].dot(mean);
  }
  Eigen::Matrix2d A;
  A << normal[0].transpose(), normal[1].transpose();
  if (std::abs(A.determinant()) < 1e-6) return std::nullopt;
  return Eigen::Vector2d(A.inverse() * Eigen::Vector2d(offset[0], offset[1]));
}

}  // namespace owlcal::fitting
