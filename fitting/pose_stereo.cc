#include "fitting/pose_stereo.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "fitting/head_gauge.h"
#include "models/units.h"

namespace owlcal::fitting {
namespace {

// The four eye servos (the neck turns both eyes together and drops out of R, T).
constexpr models::ServoIndex kEyeServos[4] = {models::kRx, models::kRy, models::kLx, models::kLy};

Eigen::Matrix3d RotZyx(double roll, double yaw, double pitch) {
  return (Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

// Central-difference step per parameter, in its result unit (the maps are smooth; these are
// far below each parameter's sigma and far above rounding).
double StepFor(const std::string& name) {
  if (name.find("deg_per_us") != std::string::npos) return 1e-5;
  if (name.find("_deg") != std::string::npos) return 1e-3;
  return 1e-2;  // us, mm
}

// [rotation vector of b * a^-1 (rad), b.t - a.t (m)].
Eigen::Matrix<double, 6, 1> Difference(const models::Rigid3d& b, const models::Rigid3d& a) {
  const Eigen::AngleAxisd d(b.rotation * a.rotation.inverse());
  Eigen::Matrix<double, 6, 1> v;
  v.head<3>() = d.angle() * d.axis();
  v.tail<3>() = b.translation - a.translation;
  return v;
}

std::array<double, models::kNumServos> ToDouble(const models::PwmVector& p) {
  std::array<double, models::kNumServos> d{};
  for (int i = 0; i < models::kNumServos; ++i) d[i] = p[i];
  return d;
}

}  // namespace

bool PoseStereoOptions::Check(std::string* why) const {
  for (int a : approach)
    if (a < -1 || a > 1) {
      if (why) *why = "approach must be -1, 0 or +1 per servo";
      return false;
    }
  if (!(rectify_alpha == -1 || (rectify_alpha >= 0 && rectify_alpha <= 1))) {
    if (why) *why = "rectify_alpha must be -1 or in [0, 1]";
    return false;
  }
  return true;
}

std::vector<std::string> PoseStereoParameterNames() {
  std::vector<std::string> n;
  for (models::ServoIndex s : kEyeServos)
    for (const char* f : kServoParamNames) n.push_back(std::string("servo.") + models::kServoNames[s] + "." + f);
  for (const char* c : {"head.left.centre_x_mm",
                        "head.left.centre_y_mm",
                        "head.left.centre_z_mm",
                        "head.right.centre_x_mm",
                        "head.right.centre_y_mm"})
    n.push_back(c);
  for (const char* e : {"left", "right"})
    for (const char* f : {"mount_roll_deg", "mount_yaw_deg", "mount_x_mm", "mount_y_mm", "mount_z_mm"})
      n.push_back(std::string("head.") + e + "." + f);
  return n;
}

bool PerturbHeadGeometry(const std::string& name, double delta, models::HeadModel* head) {
  if (name.rfind("servo.", 0) == 0) return PerturbHead(name, delta, head);
  for (int e = 0; e < 2; ++e) {
    const std::string prefix = std::string("head.") + models::kEyeNames[e] + ".";
    if (name.rfind(prefix, 0) != 0) continue;
    const std::string field = name.substr(prefix.size());
    Eigen::Vector3d& c = head->geometry.centre_in_head[e];
    models::Rigid3d& m = head->geometry.cam_from_eye[e];
    if (field == "centre_x_mm") {
      c.x() += delta * 1e-3;
    } else if (field == "centre_y_mm") {
      c.y() += delta * 1e-3;
    } else if (field == "centre_z_mm") {
      // Both centres share z (the head-yaw gauge): the left one's parameter moves both; the
      // right one's is derived, not a parameter.
      if (e != 0) return false;
      head->geometry.centre_in_head[0].z() += delta * 1e-3;
      head->geometry.centre_in_head[1].z() += delta * 1e-3;
    } else if (field == "mount_roll_deg" || field == "mount_yaw_deg") {
      const Eigen::Matrix3d r = m.rotation.toRotationMatrix();
      double yaw = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
      double roll = std::atan2(r(1, 0), r(0, 0));
      const double pitch = std::atan2(r(2, 1), r(2, 2));
      (field == "mount_roll_deg" ? roll : yaw) += delta * kDegToRad;
      m.rotation = Eigen::Quaterniond(RotZyx(roll, yaw, pitch));
    } else if (field == "mount_x_mm" || field == "mount_y_mm" || field == "mount_z_mm") {
      m.translation[field[6] - 'x'] += delta * 1e-3;
    } else {
      return false;
    }
    return true;
  }
  return false;
}

models::Rigid3d RightFromLeftAtPose(const models::HeadModel& head,
                                    const std::array<double, models::kNumServos>& pwm_us,
                                    const std::array<int, models::kNumServos>& approach) {
  const models::JointAngles a = head.Angles(pwm_us, approach);
  models::Rigid3d cam_from_head[2];
  for (int e = 0; e < 2; ++e)
    cam_from_head[e] =
        head.geometry.cam_from_eye[e] *
        models::HeadFromEye(head.geometry.centre_in_head[e].data(), a.pan_rad[e], a.tilt_rad[e]).Inverse();
  return cam_from_head[models::kRightEye] * cam_from_head[models::kLeftEye].Inverse();
}

PoseStereo StereoAtPose(const models::HeadModel& head,
                        const NamedCovariance& cov,
                        const models::PwmVector& pwm_us,
                        const PoseStereoOptions& options) {
  PoseStereo s;
  s.pwm_us = pwm_us;
  std::string why;
  if (!options.Check(&why)) {
    s.message = "PoseStereoOptions: " + why;
    return s;
  }
  if (cov.matrix.rows() != static_cast<Eigen::Index>(cov.names.size()) || cov.matrix.cols() != cov.matrix.rows()) {
    s.message = "the covariance has " + std::to_string(cov.matrix.rows()) + " rows for " +
                std::to_string(cov.names.size()) + " names";
    return s;
  }
  const auto pwm = ToDouble(pwm_us);
  s.right_from_left = RightFromLeftAtPose(head, pwm, options.approach);
  if (!s.right_from_left.translation.allFinite() || !s.right_from_left.rotation.coeffs().allFinite()) {
    s.message = "the head model gives no finite camera poses at this command";
    return s;
  }

  // J over the covariance's parameters that R, T depend on.
  std::vector<int> used;
  std::vector<Eigen::Matrix<double, 6, 1>> columns;
  for (size_t k = 0; k < cov.names.size(); ++k) {
    const std::string& n = cov.names[k];
    models::HeadModel hp = head, hm = head;
    const double h = StepFor(n);
    if (!PerturbHeadGeometry(n, h, &hp) || !PerturbHeadGeometry(n, -h, &hm)) continue;
    const Eigen::Matrix<double, 6, 1> d =
        (Difference(RightFromLeftAtPose(hp, pwm, options.approach), s.right_from_left) -
         Difference(RightFromLeftAtPose(hm, pwm, options.approach), s.right_from_left)) /
        (2 * h);
    if (d.norm() == 0) continue;  // e.g. hysteresis at approach 0, the neck
    used.push_back(static_cast<int>(k));
    columns.push_back(d);
    s.propagated.push_back(n);
  }
  Eigen::MatrixXd J(6, used.size()), C(used.size(), used.size());
  for (size_t a = 0; a < used.size(); ++a) {
    J.col(a) = columns[a];
    for (size_t b = 0; b < used.size(); ++b) C(a, b) = cov.matrix(used[a], used[b]);
  }
  s.covariance = J * C * J.transpose();
  // Unknown approach side: the half backlash band as a uniform pulse-width error.
  for (models::ServoIndex sv : kEyeServos) {
    const double h_us = head.servo_params[sv][4];
    if (options.approach[sv] != 0 || !(h_us > 0)) continue;
    auto p = pwm, m = pwm;
    p[sv] += 0.5;
    m[sv] -= 0.5;
    const Eigen::Matrix<double, 6, 1> d =
        Difference(RightFromLeftAtPose(head, p, options.approach), s.right_from_left) -
        Difference(RightFromLeftAtPose(head, m, options.approach), s.right_from_left);
    s.covariance += d * d.transpose() * (h_us * h_us / 12.0);
  }
  // The result and OpenCV's fields, as the centre pose's.
  CalibrationResult& r = s.result;
  r.head = head;
  for (int e = 0; e < 2; ++e) r.cameras[e] = head.intrinsics[e];
  StereoEstimate st;
  st.right_from_left = s.right_from_left;
  st.covariance = s.covariance;
  r.stereo = st;
  r.diagnostics["stereo"]["length_unit"] = "m";
  const Eigen::AngleAxisd aa(s.right_from_left.rotation);
  const Eigen::Vector3d rv = aa.angle() * aa.axis();
  const Eigen::Vector3d t = s.right_from_left.translation;
  const char* rn[3] = {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"};
  const char* tn[3] = {"stereo.tx", "stereo.ty", "stereo.tz"};
  const std::string note = "predicted from the head fit at this command";
  for (int j = 0; j < 3; ++j) {
    r.Set({rn[j], rv(j) / kDegToRad, std::sqrt(s.covariance(j, j)) / kDegToRad, "deg", std::nullopt, true, note});
    r.Set({tn[j], t(j) * 1000, std::sqrt(s.covariance(3 + j, 3 + j)) * 1000, "mm", std::nullopt, true, note});
  }
  const Eigen::Vector3d u = t.normalized();
  const double var_b = u.transpose() * s.covariance.block<3, 3>(3, 3) * u;
  r.Set(
      {"stereo.baseline_mm", t.norm() * 1000, std::sqrt(std::max(0.0, var_b)) * 1000, "mm", std::nullopt, true, note});
  r.inputs["pose"] = {{"pwm_us", pwm_us}, {"approach", options.approach}, {"propagated", s.propagated}};
  try {
    s.opencv =
        MakeOpenCvCalibration(head.intrinsics[0], head.intrinsics[1], s.right_from_left, "m", options.rectify_alpha);
  } catch (const std::exception& e) {
    s.message = std::string("no OpenCV calibration at this pose: ") + e.what();
    return s;
  }
  s.ok = true;
  return s;
}

PoseStereo StereoAtPose(const CalibrationResult& result,
                        const models::PwmVector& pwm_us,
                        const PoseStereoOptions& options) {
  PoseStereo s;
  s.pwm_us = pwm_us;
  if (!result.head) {
    s.message = "the result has no head model (run owlcal calibrate with the servo sweep)";
    return s;
  }
  bool fitted = false;
  for (models::ServoIndex sv : kEyeServos) {
    const Parameter* p = result.Find(std::string("servo.") + models::kServoNames[sv] + ".deg_per_us");
    fitted |= p && p->determined;
  }
  if (!fitted) {
    s.message =
        "the result's head was not fitted (no eye servo map determined): its poses are the nominal head's guess";
    return s;
  }
  PoseStereo out =
      StereoAtPose(*result.head, CovarianceFromResult(result, PoseStereoParameterNames()), pwm_us, options);
  if (!out.ok) return out;
  // The head's own parameters come along (the servo maps, the IPD), so the pose's folder gets the
  // same exports as the centre pose's (owl-pwm.h, the pixel -> PWM map).
  for (const Parameter& p : result.parameters)
    if (p.name.rfind("servo.", 0) == 0 || p.name.rfind("head.", 0) == 0) out.result.Set(p);
  // Parameters R, T depend on that the fit did not determine (a gauge convention is not an error:
  // it moves nothing the cameras see).
  const auto pwm = ToDouble(pwm_us);
  for (const std::string& n : PoseStereoParameterNames()) {
    const Parameter* p = result.Find(n);
    if (!p || p->determined || p->note.find("gauge") != std::string::npos) continue;
    models::HeadModel hp = *result.head;
    if (PerturbHeadGeometry(n, StepFor(n), &hp) &&
        Difference(RightFromLeftAtPose(hp, pwm, options.approach), out.right_from_left).norm() > 0) {
      out.not_propagated.push_back(n);
      out.result.warnings.push_back("pose calibration: " + n + " was not determined by the head fit (" + p->note +
                                    "); its error is not in the sigma");
    }
  }
  out.result.inputs["pose"]["not_propagated"] = out.not_propagated;
  return out;
}

}  // namespace owlcal::fitting
