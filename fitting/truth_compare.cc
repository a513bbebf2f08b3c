#include "fitting/truth_compare.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "models/head_kinematics.h"

namespace owlcal::fitting {

int FillTruth(const std::map<std::string, double>& truth, CalibrationResult* result, bool overwrite) {
  int n = 0;
  for (Parameter& p : result->parameters) {
    const auto it = truth.find(p.name);
    if (it == truth.end() || (p.truth && !overwrite)) continue;
    p.truth = it->second;
    ++n;
  }
  return n;
}

std::map<std::string, double> IntrinsicsTruthValues(const models::HeadModel& truth) {
  static const char* kNames[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
  std::map<std::string, double> m;
  for (int e = 0; e < 2; ++e) {
    const auto& p = truth.intrinsics[e].params;
    for (size_t i = 0; i < p.size() && i < 12; ++i) m[std::string(models::kEyeNames[e]) + "." + kNames[i]] = p[i];
  }
  return m;
}

std::map<std::string, double> StereoTruthValues(const models::HeadModel& truth, const models::PwmVector& pwm_us,
                                                const std::array<int, models::kNumServos>& approach) {
  std::array<double, models::kNumServos> pwm;
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = pwm_us[i];
  const models::JointAngles a = truth.Angles(pwm, approach);
  models::Rigid3d cam_from_base[2];
  for (int e = 0; e < 2; ++e) {
    cam_from_base[e] = truth.geometry.cam_from_eye[e] *
                       models::HeadFromEye(truth.geometry.centre_in_head[e].data(), a.pan_rad[e], a.tilt_rad[e]).Inverse() *
                       models::HeadFromBase(a.neck_rad);
  }
  const models::Rigid3d right_from_left = cam_from_base[1] * cam_from_base[0].Inverse();
  const Eigen::AngleAxisd aa(right_from_left.rotation);
  const Eigen::Vector3d rv = aa.axis() * aa.angle() * 180.0 / M_PI;
  const Eigen::Vector3d t = right_from_left.translation * 1000.0;
  return {{"stereo.baseline_mm", t.norm()}, {"stereo.tx", t.x()},          {"stereo.ty", t.y()},
          {"stereo.tz", t.z()},             {"stereo.tx_mm", t.x()},       {"stereo.ty_mm", t.y()},
          {"stereo.tz_mm", t.z()},          {"stereo.rx_deg", rv.x()},     {"stereo.ry_deg", rv.y()},
          {"stereo.rz_deg", rv.z()}};
}

TruthComparison CompareWithTruth(const CalibrationResult& result) {
  TruthComparison c;
  double sum_z2 = 0;
  int within = 0;
  for (const Parameter& p : result.parameters) {
    if (!p.truth) {
      if (p.determined) c.missing_truth.push_back(p.name);
      continue;
    }
    TruthRow r;
    r.name = p.name;
    r.unit = p.unit;
    r.value = p.value;
    r.sigma = p.sigma;
    r.truth = *p.truth;
    r.error = p.value - *p.truth;
    r.determined = p.determined;
    const bool has_sigma = p.determined && std::isfinite(p.sigma) && p.sigma > 0;
    r.z = has_sigma ? r.error / p.sigma : std::numeric_limits<double>::quiet_NaN();
    r.within_2sigma = has_sigma && std::abs(r.z) <= 2.0;
    if (has_sigma) {
      ++c.num_with_sigma;
      sum_z2 += r.z * r.z;
      within += r.within_2sigma;
      if (std::abs(r.z) > std::abs(c.worst_z)) {
        c.worst_z = r.z;
        c.worst = r.name;
      }
    }
    c.rows.push_back(r);
  }
  if (c.num_with_sigma > 0) {
    c.fraction_within_2sigma = double(within) / c.num_with_sigma;
    c.rms_z = std::sqrt(sum_z2 / c.num_with_sigma);
  }
  return c;
}

}  // namespace owlcal::fitting
