#include "evaluation/truth_compare.h"

#include "evaluation/projection_diff.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "models/head_kinematics.h"

namespace owlcal::evaluation {

int FillTruth(const std::map<std::string, double>& truth, fitting::CalibrationResult* result, bool overwrite) {
  int n = 0;
  for (fitting::Parameter& p : result->parameters) {
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

std::map<std::string, double> StereoTruthValues(const models::HeadModel& truth,
                                                const models::PwmVector& pwm_us,
                                                const std::array<int, models::kNumServos>& approach) {
  std::array<double, models::kNumServos> pwm;
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = pwm_us[i];
  const models::JointAngles a = truth.Angles(pwm, approach);
  models::Rigid3d cam_from_base[2];
  for (int e = 0; e < 2; ++e) {
    cam_from_base[e] =
        truth.geometry.cam_from_eye[e] *
        models::HeadFromEye(truth.geometry.centre_in_head[e].data(), a.pan_rad[e], a.tilt_rad[e]).Inverse() *
        models::HeadFromBase(a.neck_rad);
  }
  const models::Rigid3d right_from_left = cam_from_base[1] * cam_from_base[0].Inverse();
  const Eigen::AngleAxisd aa(right_from_left.rotation);
  const Eigen::Vector3d rv = aa.axis() * aa.angle() * 180.0 / M_PI;
  const Eigen::Vector3d t = right_from_left.translation * 1000.0;
  return {{"stereo.baseline_mm", t.norm()},
          {"stereo.tx", t.x()},
          {"stereo.ty", t.y()},
          {"stereo.tz", t.z()},
          {"stereo.tx_mm", t.x()},
          {"stereo.ty_mm", t.y()},
          {"stereo.tz_mm", t.z()},
          {"stereo.rx_deg", rv.x()},
          {"stereo.ry_deg", rv.y()},
          {"stereo.rz_deg", rv.z()}};
}

TruthComparison CompareWithTruth(const fitting::CalibrationResult& result) {
  TruthComparison c;
  double sum_z2 = 0;
  int within = 0;
  for (const fitting::Parameter& p : result.parameters) {
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

int CompareLensByProjection(const models::HeadModel& truth,
                            const std::array<const models::CameraIntrinsics*, 2>& fitted,
                            const std::vector<std::string>& prefixes,
                            fitting::CalibrationResult* result) {
  static const char* kCoefficients[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
  auto model_name = [](models::DistortionModel m) {
    return m == models::DistortionModel::kOpenCv8 ? "opencv8" : "opencv5";
  };
  int compared = 0;
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics& t = truth.intrinsics[e];
    if (!fitted[e] || fitted[e]->model == t.model) continue;
    ++compared;
    const std::string eye = models::kEyeNames[e];
    for (const std::string& prefix : prefixes)
      for (const char* c : kCoefficients)
        for (auto& p : result->parameters)
          if (p.name == prefix + eye + "." + c) p.truth.reset();
    const ProjectionDiff whole = CompareProjection(t, *fitted[e], 16, 12, 0.6);
    nlohmann::json j = {{"fitted_model", model_name(fitted[e]->model)},
                        {"truth_model", model_name(t.model)},
                        {"ok", whole.ok},
                        {"message", whole.message},
                        {"note",
                         "the fitted lens model is not the truth's: compared by projection (through the truth, "
                         "back through the fit, best rotation taken out), not coefficient by coefficient"}};
    if (whole.ok) {
      std::vector<double> inner;
      const double cx = (t.width - 1) / 2.0, cy = (t.height - 1) / 2.0, half = std::hypot(cx, cy);
      for (size_t i = 0; i < whole.pixels.size(); ++i)
        if (std::hypot(whole.pixels[i].x() - cx, whole.pixels[i].y() - cy) <= 0.6 * half)
          inner.push_back(whole.diff_px[i]);
      double ss = 0;
      for (double d : whole.diff_px) ss += d * d;
      double ss_inner = 0, max_inner = 0;
      for (double d : inner) ss_inner += d * d, max_inner = std::max(max_inner, d);
      j["rms_px"] = std::sqrt(ss / whole.diff_px.size());
      j["max_px"] = whole.max_px;
      j["median_px"] = whole.median_px;
      j["inner_rms_px"] = inner.empty() ? NAN : std::sqrt(ss_inner / inner.size());
      j["inner_max_px"] = max_inner;
      j["rotation_deg"] = whole.rotation_deg;
    }
    result->diagnostics["lens_truth"][eye] = j;
  }
  return compared;
}

}  // namespace owlcal::evaluation
