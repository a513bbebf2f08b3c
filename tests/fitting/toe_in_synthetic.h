#pragma once
// Synthetic toe-in sets with known truth for the fit-toe-in tests: observations of a 9x6 board
// (26 mm squares) seen by two cameras whose pan follows known per-eye maps, with corner noise
// and per-set servo repeatability.
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "calib/observation.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::test_toe_in {

constexpr double kDeg = M_PI / 180;

struct Truth {
  double rx_centre = 1545, lx_centre = 1545;
  double rx_deg_per_us = 0.1, lx_deg_per_us = 0.09;  // different on purpose
  double mount_yaw_deg = 0.8;                        // left eye's mounting yaw
  double repeatability_deg = 0.25;                   // per set, per eye
};

// Observations of one set: 14 board poses seen by both eyes, corner noise 0.15 px.
inline std::vector<calib::CornerObservation> SynthesiseSet(const Truth& t,
                                                           double rx_us,
                                                           double lx_us,
                                                           std::mt19937* rng) {
  std::normal_distribution<double> rep(0, t.repeatability_deg * kDeg), px(0, 0.15);
  const double th[2] = {t.lx_deg_per_us * (lx_us - t.lx_centre) * kDeg + t.mount_yaw_deg * kDeg + rep(*rng),
                        t.rx_deg_per_us * (rx_us - t.rx_centre) * kDeg + rep(*rng)};
  models::CameraIntrinsics cam;
  cam.params = {585, 583, 322, 236, -0.12, 0.08, 0.001, -0.0005, 0};
  // head_from_cam per eye: at (-+32.5 mm, 0, 0), panned about y by theta (positive: right).
  models::Rigid3d head_from_cam[2];
  for (int e = 0; e < 2; ++e) {
    head_from_cam[e].rotation = Eigen::AngleAxisd(th[e], Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd((e ? -0.6 : 0.4) * kDeg, Eigen::Vector3d::UnitX());
    head_from_cam[e].translation = Eigen::Vector3d(e ? 0.0325 : -0.0325, 0, 0);
  }
  std::vector<calib::CornerObservation> obs;
  std::uniform_real_distribution<double> u(-1, 1);
  int frame = 0;
  for (int attempt = 0; attempt < 200 && frame < 14; ++attempt) {
    models::Rigid3d head_from_board;
    head_from_board.rotation = Eigen::AngleAxisd(35 * kDeg * u(*rng), Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(35 * kDeg * u(*rng), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(10 * kDeg * u(*rng), Eigen::Vector3d::UnitZ());
    const double z = 0.45 + 0.2 * u(*rng);
    head_from_board.translation = Eigen::Vector3d(0.12 * u(*rng), 0.08 * u(*rng), z) -
                                  head_from_board.rotation * Eigen::Vector3d(4 * 0.026, 2.5 * 0.026, 0);
    std::vector<calib::CornerObservation> frame_obs;
    bool all = true;
    for (int e = 0; e < 2 && all; ++e) {
      const models::Rigid3d cam_from_board = head_from_cam[e].Inverse() * head_from_board;
      for (int r = 0; r < 6 && all; ++r) {
        for (int c = 0; c < 9 && all; ++c) {
          const Eigen::Vector3d p(c * 0.026, r * 0.026, 0);
          const Eigen::Vector3d x = cam_from_board * p;
          Eigen::Vector2d q;
          all = cam.Project(x.data(), q.data()) && q.x() > 5 && q.y() > 5 && q.x() < 634 && q.y() < 474;
          calib::CornerObservation o;
          o.frame_index = frame;
          o.eye = e;
          o.target_id = "board";
          o.corner_id = r * 9 + c;
          o.pixel = q + Eigen::Vector2d(px(*rng), px(*rng));
          o.point_in_target = p;
          frame_obs.push_back(o);
        }
      }
    }
    if (!all) continue;
    obs.insert(obs.end(), frame_obs.begin(), frame_obs.end());
    ++frame;
  }
  return obs;
}

struct Setting {
  double rx, lx;
};

// Toe-in settings 0/18/36/54 us on both eyes, one eye alone at two settings, and the parallel
// setting repeated: 8 sets, as the real experiment in docs/conventions.md, Facts, with the eyes separable.
inline const std::vector<Setting> kSettings = {
    {1545, 1545}, {1527, 1563}, {1509, 1581}, {1491, 1599}, {1545, 1581}, {1509, 1545}, {1545, 1545}, {1500, 1545}};

}  // namespace owlcal::test_toe_in
