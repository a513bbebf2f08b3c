#include "fitting/board_synthetic.h"

#include <cmath>

#include <Eigen/Geometry>

namespace owlcal::fitting {

models::Rigid3d RandomBoardPose(const calib::TargetDefinition& board, const BoardPoseSpread& s, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d half(0.5 * (board.cols - 1) * board.square_m, 0.5 * (board.rows - 1) * board.square_m, 0);
  const Eigen::Vector3d axis(u(*rng), u(*rng), 0.2 * u(*rng));
  const Eigen::Quaterniond q(
      Eigen::AngleAxisd(s.tilt_min_rad + s.tilt_range_rad * std::abs(u(*rng)), axis.normalized()));
  const Eigen::Vector3d t =
      Eigen::Vector3d(
          s.centre_x_m + s.spread_x_m * u(*rng), s.spread_y_m * u(*rng), s.depth_m + s.spread_z_m * u(*rng)) -
      q * half;
  return models::Rigid3d(q, t);
}

calib::View ProjectBoardView(const models::CameraIntrinsics& cam,
                             const calib::TargetDefinition& board,
                             const models::Rigid3d& cam_from_target,
                             double noise_px,
                             std::mt19937* rng) {
  std::normal_distribution<double> noise(0, noise_px);
  calib::View v;  // frame, eye and target_id are the caller's
  for (const auto& [id, p] : board.Corners()) {
    const Eigen::Vector3d pc = cam_from_target * p;
    double px[2];
    if (!cam.Project(pc.data(), px) || px[0] < 0 || px[1] < 0 || px[0] > cam.width - 1 || px[1] > cam.height - 1)
      continue;
    v.corner_ids.push_back(id);
    v.pixels.emplace_back(px[0] + noise(*rng), px[1] + noise(*rng));
    v.points_in_target.push_back(p);
  }
  return v;
}

}  // namespace owlcal::fitting
