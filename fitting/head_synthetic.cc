#include "fitting/head_synthetic.h"

#include <cmath>

#include <Eigen/Geometry>

#include "models/units.h"

namespace owlcal::fitting {
namespace {

using models::kLeftEye;
using models::kNeck;
using models::kNumServos;
using models::kRightEye;

double Uniform(std::mt19937_64* rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(*rng);
}
double Normal(std::mt19937_64* rng, double sigma) { return std::normal_distribution<double>(0.0, sigma)(*rng); }

// Board whose centre sits at `distance_m` along (yaw, pitch) from the base origin, facing it,
// turned by a random small rotation.
models::Rigid3d BoardPose(
    const calib::TargetDefinition& board, double yaw_deg, double pitch_deg, double distance_m, std::mt19937_64* rng) {
  const double yaw = yaw_deg * kDegToRad, pitch = pitch_deg * kDegToRad;
  const Eigen::Vector3d v(std::sin(yaw) * std::cos(pitch), -std::sin(pitch), std::cos(yaw) * std::cos(pitch));
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(v).normalized();
  const Eigen::Vector3d y = v.cross(x);
  Eigen::Matrix3d r;
  r.col(0) = x;
  r.col(1) = y;
  r.col(2) = v;
  const Eigen::Vector3d axis = Eigen::Vector3d(Normal(rng, 1), Normal(rng, 1), Normal(rng, 0.3)).normalized();
  r = r * Eigen::AngleAxisd(Uniform(rng, 5, 15) * kDegToRad, axis).toRotationMatrix();
  const double w = (board.cols - 1) * board.square_m, h = (board.rows - 1) * board.square_m;
  const Eigen::Vector3d centre = distance_m * v + Eigen::Vector3d(0, 0, 0.03);
  return models::Rigid3d(Eigen::Quaterniond(r), centre - r * Eigen::Vector3d(w / 2, h / 2, 0));
}

}  // namespace

models::HeadModel PerturbedHead(const models::RobotConfig& robot,
                                std::mt19937_64* rng,
                                double mount_pitch_deg_sigma,
                                bool canonical) {
  models::HeadModel h = models::NominalHeadModel(robot);
  for (int i = 0; i < kNumServos; ++i) {
    auto& p = h.servo_params[i];
    p[0] = robot.servos[i].centre_us + (i == kNeck && canonical ? 0.0 : Uniform(rng, -40, 40));
    p[1] = Uniform(rng, 0.10, 0.125);
    p[2] = Uniform(rng, -1.0, 1.0);
    p[3] = Uniform(rng, -1.5, 1.5);
    p[4] = Uniform(rng, 2.0, 4.0);
  }
  const double ipd = 0.0638 + Uniform(rng, -0.0005, 0.0005);
  const double mid_x = Uniform(rng, -0.001, 0.001);
  const double z = 0.03 + Uniform(rng, -0.003, 0.003);
  h.geometry.centre_in_head[kLeftEye] =
      Eigen::Vector3d(mid_x - ipd / 2, canonical ? 0.0 : Uniform(rng, -0.001, 0.001), z);
  h.geometry.centre_in_head[kRightEye] =
      Eigen::Vector3d(mid_x + ipd / 2, Uniform(rng, -0.001, 0.001), canonical ? z : z + Uniform(rng, -0.002, 0.002));
  for (int e = 0; e < 2; ++e) {
    const double roll = Normal(rng, 1.0) * kDegToRad, yaw = Normal(rng, 1.0) * kDegToRad;
    const double pitch = Normal(rng, mount_pitch_deg_sigma) * kDegToRad;
    const Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ())) *
                                 Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX());
    const Eigen::Vector3d t(
        Uniform(rng, -0.003, 0.003), Uniform(rng, -0.003, 0.003), 0.015 + Uniform(rng, -0.003, 0.003));
    h.geometry.cam_from_eye[e] = models::Rigid3d(q, t);
    const double f = 580 + Uniform(rng, -10, 10);
    h.intrinsics[e].params = {f * (1 + Uniform(rng, -0.002, 0.002)),
                              f,
                              319.5 + Uniform(rng, -5, 5),
                              239.5 + Uniform(rng, -5, 5),
                              -0.12 + Uniform(rng, -0.03, 0.03),
                              0.08 + Uniform(rng, -0.02, 0.02),
                              Uniform(rng, -0.001, 0.001),
                              Uniform(rng, -0.001, 0.001),
                              0.0};
  }
  return h;
}

SyntheticHeadData SynthesizeHeadViews(const models::HeadModel& truth,
                                      const models::RobotConfig& robot,
                                      const SyntheticHeadOptions& options,
                                      std::mt19937_64* rng) {
  SyntheticHeadData data;
  // Fixed boards around the head.
  const struct {
    const char* id;
    double yaw, pitch, dist;
  } placements[] = {{"near", 0, 0, 0.5},
                    {"far", 8, 4, 1.0},
                    {"left", -32, 0, 0.7},
                    {"right", 32, 0, 0.7},
                    {"up", 0, 28, 0.7},
                    {"down", 0, -28, 0.7}};
  for (const auto& pl : placements)
    data.base_from_target[pl.id] = BoardPose(options.board, pl.yaw, pl.pitch, pl.dist, rng);
  const std::map<int, Eigen::Vector3d> corners = options.board.Corners();

  // Pose sequence.
  const models::PwmVector centre = robot.Centre();
  auto lo = [&](int s) { return centre[s] - options.sweep_fraction * (centre[s] - robot.servos[s].min_us); };
  auto hi = [&](int s) { return centre[s] + options.sweep_fraction * (robot.servos[s].max_us - centre[s]); };
  auto at = [&](int s, double f) { return int(std::lround(lo(s) + f * (hi(s) - lo(s)))); };
  std::vector<models::PwmVector>& poses = data.poses;
  const int n = std::max(options.steps_per_sweep, 2);
  for (int s : {models::kRx, models::kRy, models::kLx, models::kLy}) {
    for (int k = 0; k < n; ++k) {
      models::PwmVector p = centre;
      p[s] = at(s, double(k) / (n - 1));
      poses.push_back(p);
    }
    for (int k = n - 1; k >= 0; --k) {
      models::PwmVector p = centre;
      // Offset the way down by half a step so the two directions sample different widths.
      p[s] = at(s, std::clamp((k + 0.5) / (n - 1), 0.0, 1.0));
      poses.push_back(p);
    }
    poses.push_back(centre);
  }
  const int g = std::max(options.grid_side, 0);
  for (int i = 0; i < g; ++i) {
    for (int jj = 0; jj < g; ++jj) {
      const int j = (i % 2 == 0) ? jj : g - 1 - jj;
      const double fp = g > 1 ? double(j) / (g - 1) : 0.5, ft = g > 1 ? double(i) / (g - 1) : 0.5;
      models::PwmVector p = centre;
      p[models::kRx] = at(models::kRx, 0.1 + 0.8 * fp);
      p[models::kLx] = at(models::kLx, 0.1 + 0.8 * fp);
      p[models::kRy] = at(models::kRy, 0.1 + 0.8 * ft);
      p[models::kLy] = at(models::kLy, 0.9 - 0.8 * ft);  // mirrored: same direction of gaze
      poses.push_back(p);
    }
  }
  if (options.move_neck) {
    const int m = std::max(options.neck_steps, 2);
    for (int k = 0; k < m; ++k) {
      models::PwmVector p = centre;
      p[kNeck] = at(kNeck, 0.1 + 0.8 * k / (m - 1));
      poses.push_back(p);
    }
    for (int k = m - 1; k >= 0; --k) {
      models::PwmVector p = centre;
      p[kNeck] = at(kNeck, 0.1 + 0.8 * (k + 0.5) / (m - 1));
      poses.push_back(p);
    }
    poses.push_back(centre);
  }

  // Views along the sequence.
  std::array<int, kNumServos> last = centre;
  std::array<int, kNumServos> approach{};
  std::normal_distribution<double> noise(0.0, options.noise_px);
  for (size_t f = 0; f < poses.size(); ++f) {
    const models::PwmVector& p = poses[f];
    for (int s = 0; s < kNumServos; ++s) {
      if (p[s] > last[s]) approach[s] = 1;
      if (p[s] < last[s]) approach[s] = -1;
      last[s] = p[s];
    }
    std::array<double, kNumServos> pwm;
    for (int s = 0; s < kNumServos; ++s) pwm[s] = p[s];
    const models::JointAngles angles = truth.Angles(pwm, approach);
    for (int eye : {kLeftEye, kRightEye}) {
      for (const auto& [id, base_from_target] : data.base_from_target) {
        calib::View v;
        v.frame_index = static_cast<int>(f);
        v.eye = eye;
        v.target_id = id;
        v.pwm_us = p;
        for (int s = 0; s < kNumServos; ++s) v.approach[s] = static_cast<int8_t>(approach[s]);
        v.stamp_ns = static_cast<int64_t>(f) * 100'000'000;
        for (const auto& [cid, pt] : corners) {
          const Eigen::Vector3d x_in_cam = truth.PointInCam(models::Eye(eye), angles, base_from_target * pt);
          if (x_in_cam.z() < 0.05) continue;
          Eigen::Vector2d px;
          if (!truth.Project(models::Eye(eye), angles, base_from_target * pt, &px)) continue;
          const auto& cam = truth.intrinsics[eye];
          // Keep corners inside the image and within the lens' sane field (|x/z| < 1).
          if (px.x() < 0 || px.y() < 0 || px.x() > cam.width - 1 || px.y() > cam.height - 1) continue;
          if (std::abs(x_in_cam.x() / x_in_cam.z()) > 0.7 || std::abs(x_in_cam.y() / x_in_cam.z()) > 0.6) continue;
          v.corner_ids.push_back(cid);
          v.pixels.push_back(px + Eigen::Vector2d(noise(*rng), noise(*rng)));
          v.points_in_target.push_back(pt);
        }
        if (static_cast<int>(v.pixels.size()) >= options.min_corners) data.views.push_back(std::move(v));
      }
    }
  }
  return data;
}

}  // namespace owlcal::fitting
