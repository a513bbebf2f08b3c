#include "fitting/head_gauge.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "models/head_kinematics.h"
#include "models/servo_map.h"
#include "models/units.h"

namespace owlcal::fitting {
namespace {

using models::kLeftEye;
using models::kNeck;
using models::kNumServos;
using models::kRightEye;
using models::ServoMap;

}  // namespace

std::vector<Parameter> HeadParameters(const models::HeadModel& head, bool with_intrinsics) {
  std::vector<Parameter> out;
  auto add = [&](const std::string& name, double value, const std::string& unit) {
    Parameter p;
    p.name = name;
    p.value = value;
    p.unit = unit;
    out.push_back(p);
  };
  for (int i = 0; i < kNumServos; ++i)
    for (int k = 0; k < 5; ++k)
      add(std::string("servo.") + models::kServoNames[i] + "." + kServoParamNames[k],
          head.servo_params[i][k],
          kServoParamUnits[k]);
  add("head.ipd_mm", head.geometry.Ipd() * 1000, "mm");
  const char* const axes[3] = {"x", "y", "z"};
  for (int e = 0; e < 2; ++e) {
    const std::string eye = std::string("head.") + models::kEyeNames[e] + ".";
    for (int a = 0; a < 3; ++a) add(eye + "centre_" + axes[a] + "_mm", head.geometry.centre_in_head[e](a) * 1000, "mm");
    const Eigen::Matrix3d r = head.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    add(eye + "mount_roll_deg", std::atan2(r(1, 0), r(0, 0)) * kRadToDeg, "deg");
    add(eye + "mount_yaw_deg", std::asin(std::clamp(-r(2, 0), -1.0, 1.0)) * kRadToDeg, "deg");
    add(eye + "mount_pitch_deg", std::atan2(r(2, 1), r(2, 2)) * kRadToDeg, "deg");
    for (int a = 0; a < 3; ++a)
      add(eye + "mount_" + axes[a] + "_mm", head.geometry.cam_from_eye[e].translation(a) * 1000, "mm");
    if (with_intrinsics) {
      const char* names[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
      for (size_t k = 0; k < head.intrinsics[e].params.size(); ++k)
        add(eye + names[k], head.intrinsics[e].params[k], k < 4 ? "px" : "");
    }
  }
  return out;
}

void SetHeadTruth(const models::HeadModel& truth, CalibrationResult* result) {
  for (const Parameter& t : HeadParameters(truth, true)) {
    for (Parameter& p : result->parameters) {
      if (p.name == t.name) p.truth = t.value;
    }
  }
}

std::array<double, 5> ShiftServoMapAngle(const std::array<double, 5>& params, int direction, double delta_rad) {
  const double n = ServoMap::kNormUs;
  const double s = params[1], q = params[2], c = params[3];
  const double target_deg = direction * delta_rad * kRadToDeg;
  // Solve deg(delta_us) = target with deg(x) = s x + q (x/N)^2 + c (x/N)^3.
  double x = target_deg / s;
  for (int it = 0; it < 60; ++it) {
    const double f = s * x + q * (x / n) * (x / n) + c * (x / n) * (x / n) * (x / n) - target_deg;
    const double df = s + 2 * q * x / (n * n) + 3 * c * x * x / (n * n * n);
    if (df == 0) break;
    const double step = f / df;
    x -= step;
    if (std::abs(step) < 1e-14) break;
  }
  std::array<double, 5> out = params;
  out[0] = params[0] + x;
  out[1] = s + 2 * q * x / (n * n) + 3 * c * x * x / (n * n * n);
  out[2] = q + 3 * c * x / n;
  out[3] = c;
  return out;
}

models::HeadModel CanonicalHead(const models::HeadModel& head,
                                double neck_centre_us,
                                bool neck_moved,
                                const Eigen::Vector3d& left_centre_fixed) {
  models::HeadModel h = head;
  // 1. Mount pitch (ZYX Euler: R = Rz(roll) Ry(yaw) Rx(pitch)) into the tilt map: t' = t - pitch.
  for (int e = 0; e < 2; ++e) {
    const Eigen::Matrix3d r = h.geometry.cam_from_eye[e].rotation.toRotationMatrix();
    const double pitch = std::atan2(r(2, 1), r(2, 2));
    h.geometry.cam_from_eye[e].rotation = h.geometry.cam_from_eye[e].rotation * models::RotX(-pitch);
    const int tilt = models::kTiltServo[e];
    h.servo_params[tilt] = ShiftServoMapAngle(h.servo_params[tilt], h.directions[tilt], pitch);
  }
  // 2. Head yaw a such that the centres have equal z in the new head frame: c' = RotY(-a) c,
  //    pan' = pan - a.
  const Eigen::Vector3d d = h.geometry.centre_in_head[kRightEye] - h.geometry.centre_in_head[kLeftEye];
  const double a = std::atan2(-d.z(), d.x());
  for (int e = 0; e < 2; ++e) {
    h.geometry.centre_in_head[e] = models::RotY(-a) * h.geometry.centre_in_head[e];
    const int pan = models::kPanServo[e];
    h.servo_params[pan] = ShiftServoMapAngle(h.servo_params[pan], h.directions[pan], a);
  }
  // 3. Neck zero at the configured centre (the base frame absorbs a constant neck angle).
  const double neck0 = h.ServoAngle(kNeck, neck_centre_us, 0);
  h.servo_params[kNeck] = ShiftServoMapAngle(h.servo_params[kNeck], h.directions[kNeck], neck0);
  // 4. Base origin.
  Eigen::Vector3d shift = left_centre_fixed - h.geometry.centre_in_head[kLeftEye];
  if (neck_moved) shift = Eigen::Vector3d(0, shift.y(), 0);
  for (int e = 0; e < 2; ++e) h.geometry.centre_in_head[e] += shift;
  return h;
}

}  // namespace owlcal::fitting
