#include "fitting/uncertainty_map.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

namespace owlcal::fitting {
namespace {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

Mat3 ExpSo3(const Vec3& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Mat3::Identity();
}

struct Pose {
  Mat3 R;
  Vec3 t;
};

// State: free intrinsics, then 6 per board ([dr, dt], left perturbation).
struct State {
  const models::CameraIntrinsics* camera;
  std::vector<int> free;  // indices into camera->params
  std::vector<Pose> poses;
  int size() const { return static_cast<int>(free.size() + 6 * poses.size()); }

  // Camera params and one pose with state element k moved by h (k < 0: none).
  std::vector<double> Params(int k, double h) const {
    std::vector<double> p = camera->params;
    if (k >= 0 && k < static_cast<int>(free.size())) p[free[k]] += h;
    return p;
  }
  Pose PoseOf(int i, int k, double h) const {
    Pose q = poses[i];
    const int base = static_cast<int>(free.size()) + 6 * i;
    if (k >= base && k < base + 3) {
      Vec3 w = Vec3::Zero();
      w[k - base] = h;
      q.R = ExpSo3(w) * q.R;
    } else if (k >= base + 3 && k < base + 6) {
      q.t[k - base - 3] += h;
    }
    return q;
  }
};

bool ProjectWith(const models::CameraIntrinsics& cam, const std::vector<double>& p, const Vec3& x, Eigen::Vector2d* q) {
  models::CameraIntrinsics c = cam;
  c.params = p;
  return c.Project(x.data(), q->data());
}

double Step(const State& s, int k) {
  if (k < static_cast<int>(s.free.size())) return 1e-6 * std::max(1.0, std::abs(s.camera->params[s.free[k]]));
  return 1e-7;
}

}  // namespace

bool UncertaintyMapOptions::Check(std::string* why) const {
  if (grid_cols < 2 || grid_rows < 2 || distance_m < 0) {
    if (why) *why = "grid must be at least 2x2 and distance_m >= 0";
    return false;
  }
  return true;
}

double MedianBoardDistance(const IntrinsicsFit& fit) {
  std::vector<double> d;
  for (const auto& p : fit.cam_from_target) d.push_back(p.translation.norm());
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

UncertaintyMap ComputeUncertaintyMap(const IntrinsicsFit& fit,
                                     const std::vector<calib::View>& views,
                                     const std::vector<int>& fixed,
                                     const UncertaintyMapOptions& o) {
  UncertaintyMap out;
  std::string why;
  if (!o.Check(&why)) {
    out.message = why;
    return out;
  }
  if (!fit.ok || fit.cam_from_target.empty()) {
    out.message = "no successful fit";
    return out;
  }
  State s;
  s.camera = &fit.camera;
  const std::set<int> fixed_set(fixed.begin(), fixed.end());
  for (int i = 0; i < static_cast<int>(fit.camera.params.size()); ++i)
    if (!fixed_set.count(i)) s.free.push_back(i);
  std::map<int, const calib::View*> view_of;
  for (const auto& v : views) view_of[v.frame_index] = &v;
  std::set<std::pair<int, int>> rejected;
  for (const auto& r : fit.rejected) rejected.insert({r.frame_index, r.corner_id});
  std::vector<const calib::View*> used;
  for (size_t i = 0; i < fit.frame_indices.size() && i < fit.cam_from_target.size(); ++i) {
    const auto it = view_of.find(fit.frame_indices[i]);
    if (it == view_of.end()) continue;
    used.push_back(it->second);
    s.poses.push_back({fit.cam_from_target[i].rotation.toRotationMatrix(), fit.cam_from_target[i].translation});
  }
  if (used.empty()) {
    out.message = "none of the fit's views was given";
    return out;
  }
  const int n = s.size(), m = static_cast<int>(s.free.size());

  // 1. J^T J over every inlier corner; each corner touches the intrinsics and its own pose.
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(n, n);
  const std::vector<double> p0 = s.Params(-1, 0);
  for (size_t i = 0; i < used.size(); ++i) {
    const calib::View& v = *used[i];
    const int base = m + 6 * static_cast<int>(i);
    std::vector<int> cols;
    for (int k = 0; k < m; ++k) cols.push_back(k);
    for (int k = 0; k < 6; ++k) cols.push_back(base + k);
    for (size_t j = 0; j < v.pixels.size(); ++j) {
      if (rejected.count({v.frame_index, j < v.corner_ids.size() ? v.corner_ids[j] : -1})) continue;
      Eigen::MatrixXd Jl(2, cols.size());
      bool good = true;
      for (size_t c = 0; c < cols.size() && good; ++c) {
        const int k = cols[c];
        const double h = Step(s, k);
        Eigen::Vector2d qp, qm;
        const Pose pp = s.PoseOf(static_cast<int>(i), k, h), pm = s.PoseOf(static_cast<int>(i), k, -h);
        good = ProjectWith(fit.camera, s.Params(k, h), pp.R * v.points_in_target[j] + pp.t, &qp) &&
               ProjectWith(fit.camera, s.Params(k, -h), pm.R * v.points_in_target[j] + pm.t, &qm);
        Jl.col(c) = (qp - qm) / (2 * h);
      }
      if (!good) continue;
      const Eigen::MatrixXd JtJl = Jl.transpose() * Jl;
      for (size_t a = 0; a < cols.size(); ++a)
        for (size_t b = 0; b < cols.size(); ++b) JtJ(cols[a], cols[b]) += JtJl(a, b);
    }
  }
  // 2. Var(x) = sigma^2 (J^T J)^-1; a (near) null space means a parameter is not determined.
  // Columns are scaled to unit diagonal first so the condition test does not depend on units
  // (pixels, distortion coefficients, radians, metres).
  const Eigen::VectorXd d = JtJ.diagonal().cwiseMax(1e-300).cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd scaled = d.asDiagonal() * JtJ * d.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
  const Eigen::VectorXd ev = es.eigenvalues();
  if (!(ev.minCoeff() > 1e-10 * ev.maxCoeff())) {
    out.message =
        "the corners leave a combination of the intrinsics and board poses undetermined "
        "(information matrix singular: condition " +
        std::to_string(ev.maxCoeff() / std::max(ev.minCoeff(), 1e-300)) + ")";
    return out;
  }
  const double sigma = fit.corner_sigma_px > 0 ? fit.corner_sigma_px : std::max(fit.rms_px, 1e-3);
  const Eigen::MatrixXd cov = sigma * sigma * d.asDiagonal() *
                              (es.eigenvectors() * ev.cwiseInverse().asDiagonal() * es.eigenvectors().transpose()) *
                              d.asDiagonal();
  out.free_indices = s.free;
  out.intrinsics_covariance = cov.topLeftCorner(m, m);

  // 3. Each grid pixel: a point on its ray in every board's frame, reprojected through the
  // perturbed state (mean over boards of board->camera), G by central differences.
  const bool at_infinity = !(o.distance_m > 0);
  auto reproject = [&](const std::vector<Vec3>& in_board, int k, double h, Eigen::Vector2d* q) {
    Vec3 mean = Vec3::Zero();
    for (size_t i = 0; i < s.poses.size(); ++i) {
      const Pose p = s.PoseOf(static_cast<int>(i), k, h);
      mean += at_infinity ? Vec3(p.R * in_board[i]) : Vec3(p.R * in_board[i] + p.t);
    }
    mean /= static_cast<double>(s.poses.size());
    return ProjectWith(fit.camera, s.Params(k, h), mean, q);
  };
  const int W = fit.camera.width, H = fit.camera.height;
  out.grid_cols = o.grid_cols;
  out.grid_rows = o.grid_rows;
  auto sigma_at = [&](const Eigen::Vector2d& q) {
    Vec3 ray;
    if (!fit.camera.Unproject(q.data(), ray.data())) return std::numeric_limits<double>::infinity();
    ray.normalize();
    const Vec3 x = at_infinity ? ray : Vec3(ray * o.distance_m);
    std::vector<Vec3> in_board;
    for (const auto& p : s.poses)
      in_board.push_back(at_infinity ? Vec3(p.R.transpose() * x) : Vec3(p.R.transpose() * (x - p.t)));
    Eigen::MatrixXd G(2, n);
    for (int k = 0; k < n; ++k) {
      const double h = Step(s, k);
      Eigen::Vector2d qp, qm;
      if (!reproject(in_board, k, h, &qp) || !reproject(in_board, k, -h, &qm))
        return std::numeric_limits<double>::infinity();
      G.col(k) = (qp - qm) / (2 * h);
    }
    const Eigen::Matrix2d V = G * cov * G.transpose();
    return std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(V).eigenvalues()(1)));
  };
  for (int r = 0; r < o.grid_rows; ++r) {
    for (int c = 0; c < o.grid_cols; ++c) {
      const Eigen::Vector2d q((c + 0.5) * W / o.grid_cols - 0.5, (r + 0.5) * H / o.grid_rows - 0.5);
      out.pixels.push_back(q);
      out.sigma_px.push_back(sigma_at(q));
    }
  }
  out.centre_px = sigma_at(Eigen::Vector2d((W - 1) / 2.0, (H - 1) / 2.0));
  std::vector<double> sorted = out.sigma_px;
  std::sort(sorted.begin(), sorted.end());
  out.median_px = sorted[sorted.size() / 2];
  out.p90_px = sorted[std::min(sorted.size() - 1, static_cast<size_t>(0.9 * sorted.size()))];
  out.max_px = sorted.back();
  out.ok = std::isfinite(out.median_px);
  if (!out.ok) out.message = "some pixels cannot be unprojected through the fitted lens";
  return out;
}

}  // namespace owlcal::fitting
