#include "sim/robot_prior.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <vector>

#include "models/servo_map.h"

namespace owlcal::sim {
namespace {

using Uniform = std::function<double(double, double)>;

// Gives servo `s` a new nonlinearity, drawn as the prior draws it, until its map is monotone over
// its end-stops again (the other kinds move the centre and the stops after the prior's check).
void KeepPriorServoMonotone(ServoTruth* s, const Uniform& uni) {
  for (int attempt = 0;; ++attempt) {
    const auto p = s->MapParams();
    if (models::ServoMap::IsMonotone(p.data(), s->direction, s->endstop_lo_us - 50, s->endstop_hi_us + 50)) return;
    if (attempt > 100) {  // as in the prior: a linear map rather than a loop
      s->quad_deg = s->cubic_deg = 0;
      return;
    }
    s->quad_deg = uni(-1.5, 1.5);
    s->cubic_deg = uni(-1.5, 1.5);
  }
}

// kReassembled's values over a prior robot (robot_prior.h): one reversed horn, centres and stops
// off the file's, 5 us PWM, another IPD.
void ReassemblePriorRobot(RobotTruth* t, const Uniform& uni) {
  // The reversed servo: the four eye servos equally, the neck less often.
  const double pick = uni(0, 1);
  const int reversed = pick < 0.9 ? std::min(int(pick / 0.225), int(models::kLy)) : int(models::kNeck);
  for (int i = 0; i < models::kNumServos; ++i) {
    const bool neck = i == models::kNeck;
    const models::ServoConfig& c = t->robot.servos[i];
    ServoTruth& s = t->servos[i];
    s.direction = i == reversed ? -c.direction : c.direction;
    const double sign = uni(0, 1) < 0.5 ? -1 : 1;
    s.centre_us = c.centre_us + sign * (neck ? uni(40, 70) : uni(50, 90));
    s.endstop_lo_us = c.min_us + (neck ? uni(55, 75) : uni(35, 90));
    s.endstop_hi_us = c.max_us - (neck ? uni(55, 75) : uni(35, 90));
    s.quantum_us = 5;
    KeepPriorServoMonotone(&s, uni);
  }
  // The prior's eye centres moved apart symmetrically along x to the new IPD [m].
  Eigen::Vector3d& left = t->geometry.centre_in_head[models::kLeftEye];
  Eigen::Vector3d& right = t->geometry.centre_in_head[models::kRightEye];
  const double widen = (uni(0.062, 0.069) - (right.x() - left.x())) / 2;
  left.x() -= widen;
  right.x() += widen;
}

// kSlow's values over a prior robot (robot_prior.h): slow servos, a slow stream, a wide rational
// lens and wide sockets.
void SlowPriorRobot(RobotTruth* t, const Uniform& uni) {
  for (int i = 0; i < models::kNumServos; ++i) {
    const bool neck = i == models::kNeck;
    const models::ServoConfig& c = t->robot.servos[i];
    ServoTruth& s = t->servos[i];
    s.slew_deg_per_s = uni(150, 250);
    s.lag_s = uni(0.06, 0.14);
    s.hysteresis_us = neck ? uni(5, 7) : uni(2.5, 4);
    s.dead_band_us = uni(3, 7);
    if (neck) {
      s.endstop_lo_us = c.min_us + uni(30, 50);
      s.endstop_hi_us = c.max_us - uni(30, 50);
      KeepPriorServoMonotone(&s, uni);
    }
  }
  StreamTruth& st = t->stream;
  st.fps = uni(0, 1) < 0.5 ? 15 : 20;
  st.latency_ms = uni(180, 260);
  st.eye_offset_ms = uni(15, 30);
  st.rolling_shutter_ms = uni(30, 45);
  for (int e = 0; e < 2; ++e) {
    models::CameraIntrinsics& k = t->intrinsics[e];
    // params: fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6; cx, cy, p1, p2 stay the prior's.
    const std::vector<double> prior = k.params;
    const double fx = uni(500, 530);
    const double k1 = uni(6, 8);
    k.model = models::DistortionModel::kOpenCv8;
    k.params = {
        fx, fx * (1 + uni(-0.003, 0.003)), prior[2], prior[3], k1, 0, prior[6], prior[7], 0, k1 + uni(0.8, 1.2), 0, 0};
  }
  t->socket.rim_half_angle_deg = uni(70, 78);
}

}  // namespace

const char* RobotKindName(RobotKind kind) {
  switch (kind) {
    case RobotKind::kPrior:
      return "prior";
    case RobotKind::kReassembled:
      return "reassembled";
    case RobotKind::kSlow:
      return "slow";
  }
  return "?";
}

DrawnRobot DrawRobot(std::mt19937_64* rng, const std::string& name, RobotKind kind) {
  std::uniform_real_distribution<double> u01(0, 1);
  auto uni = [&](double lo, double hi) { return lo + (hi - lo) * u01(*rng); };
  DrawnRobot out;
  RobotTruth& t = out.truth;
  t = DefaultRobotTruth();
  t.name = name;
  t.robot = models::DefaultRobotConfig();
  t.robot.name = "guide-owl";

  const int quantum = u01(*rng) < 0.3 ? 5 : 1;
  for (int i = 0; i < models::kNumServos; ++i) {
    const bool neck = i == models::kNeck;
    const models::ServoConfig& c = t.robot.servos[i];
    ServoTruth& s = t.servos[i];
    s.direction = c.direction;
    s.quantum_us = quantum;
    s.endstop_lo_us = c.min_us + uni(-20, 35);
    s.endstop_hi_us = c.max_us - uni(-20, 35);
    for (int attempt = 0;; ++attempt) {
      s.centre_us = c.centre_us + (neck ? uni(-40, 40) : uni(-60, 60));
      s.deg_per_us = neck ? uni(0.100, 0.125) : uni(0.088, 0.125);
      s.quad_deg = uni(-1.5, 1.5);
      s.cubic_deg = uni(-1.5, 1.5);
      const auto p = s.MapParams();
      if (models::ServoMap::IsMonotone(p.data(), s.direction, s.endstop_lo_us - 50, s.endstop_hi_us + 50)) break;
      if (attempt > 100) {  // cannot happen with these ranges; keep the map linear rather than loop
        s.quad_deg = s.cubic_deg = 0;
        break;
      }
    }
    s.hysteresis_us = neck ? uni(2, 8) : uni(0.5, 6);
    s.dead_band_us = neck ? uni(2, 5) : uni(1, 3);
    s.slew_deg_per_s = neck ? uni(280, 360) : uni(280, 460);
    s.lag_s = neck ? uni(0.035, 0.07) : uni(0.015, 0.07);
  }

  const double ipd = uni(0.0625, 0.0655);
  const double z = uni(0.028, 0.032);
  t.geometry.centre_in_head[models::kLeftEye] =
      Eigen::Vector3d(-ipd / 2 + uni(-2e-4, 2e-4), uni(-5e-4, 5e-4), z + uni(-5e-4, 5e-4));
  t.geometry.centre_in_head[models::kRightEye] =
      t.geometry.centre_in_head[models::kLeftEye] + Eigen::Vector3d(ipd, uni(-5e-4, 5e-4), uni(-1e-3, 1e-3));
  for (int e = 0; e < 2; ++e) {
    t.geometry.cam_from_eye[e] = CamFromEyeMounting({uni(-0.002, 0.002), uni(-0.002, 0.002), uni(0.013, 0.018)},
                                                    {uni(-1.5, 1.5), uni(-1.5, 1.5), uni(-1.5, 1.5)});
    const double fx = uni(480, 620);
    models::CameraIntrinsics& k = t.intrinsics[e];
    k.model = models::DistortionModel::kOpenCv5;
    k.width = t.robot.image_width;
    k.height = t.robot.image_height;
    k.params = {fx,
                fx * (1 + uni(-0.003, 0.003)),
                (k.width - 1) / 2.0 + uni(-15, 15),
                (k.height - 1) / 2.0 + uni(-15, 15),
                -0.08 - 0.12 * (620 - fx) / 140 + uni(-0.04, 0.04),
                uni(0, 0.12),
                uni(-0.001, 0.001),
                uni(-0.001, 0.001),
                uni(-0.03, 0.01)};
  }

  StreamTruth& st = t.stream;
  st.noise_sigma = uni(0.8, 2.5);
  st.jpeg_quality = int(std::lround(uni(70, 95)));
  st.blur_px = uni(1.0, 2.2);
  st.white_level = uni(140, 200);
  st.black_level = uni(40, 70);
  st.lens_shading = uni(0.1, 0.5);
  st.eye_offset_ms = uni(-5, 12);
  st.latency_ms = uni(67, 133);
  st.drop_probability = uni(0, 0.02);
  st.rolling_shutter_ms = uni(20, 33);

  out.scene = DefaultScene();
  if (SceneTarget* board = out.scene.Find("chessboard"))
    board->warp_m = Eigen::Vector2d(uni(0, 1.2e-3), uni(-3e-4, 3e-4));
  // The other kinds' numbers come after all of the prior's, so a kPrior robot is drawn as before.
  if (kind == RobotKind::kReassembled) ReassemblePriorRobot(&t, uni);
  if (kind == RobotKind::kSlow) SlowPriorRobot(&t, uni);
  t.Validate("drawn robot " + name);
  return out;
}

}  // namespace owlcal::sim
