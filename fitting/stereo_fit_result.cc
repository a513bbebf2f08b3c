// AppendStereoToResult (fitting/stereo_fit.h): a stereo fit as named parameters of a result.
#include "fitting/stereo_fit.h"

#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Geometry>

#include "models/units.h"

namespace owlcal::fitting {
namespace {
constexpr const char* kEyeName[2] = {"left", "right"};

Eigen::Vector3d RotationVector(const Eigen::Quaterniond& q) {
  const Eigen::AngleAxisd aa(q.normalized());
  return aa.angle() * aa.axis();
}

}  // namespace

void AppendStereoToResult(const StereoFit& fit, CalibrationResult* result) {
  if (!fit.ok) {
    for (int e = 0; e < 2; ++e)
      if (fit.per_eye[e].ok || !fit.per_eye[e].message.empty())
        AppendIntrinsicsToResult(fit.per_eye[e], kEyeName[e], result);
    result->warnings.push_back("stereo: " + fit.message);
    SolveSummary s = fit.summary;
    s.problem = "stereo";
    s.message = fit.message;
    s.usable = false;
    result->summaries.push_back(s);
    const bool metres = fit.length_unit == "m";
    const std::string unit = metres ? "mm" : fit.length_unit + "s";
    result->Set({metres ? "stereo.baseline_mm" : "stereo.baseline_" + unit,
                 kNaN,
                 kNaN,
                 unit,
                 std::nullopt,
                 false,
                 fit.message});
    return;
  }
  const int np = int(fit.cameras[0].params.size());
  const std::vector<std::string> names = IntrinsicParamNames(fit.cameras[0].model);
  auto note_of = [&](const std::string& full) {
    for (const auto& u : fit.undetermined)
      if (u.rfind(full + ":", 0) == 0) return u.substr(full.size() + 2);
    return std::string();
  };
  for (int e = 0; e < 2; ++e) {
    result->cameras[e] = fit.cameras[e];
    for (int i = 0; i < np; ++i) {
      const int k = e * np + i;
      Parameter p{fit.param_names[k],
                  fit.cameras[e].params[i],
                  fit.sigmas[k],
                  IntrinsicParamUnit(names[i]),
                  std::nullopt,
                  bool(fit.determined[k]),
                  note_of(fit.param_names[k])};
      // Held by a --fix option (not fix_intrinsics, whose values are the per-eye estimates).
      p.held = !p.determined && internal::IsHeldReason(p.note) && p.note.find("fix_intrinsics") == std::string::npos;
      if (p.held) p.sigma = 0;
      result->Set(p);
    }
  }
  const bool metres = fit.length_unit == "m";
  const double f = metres ? 1000.0 : 1.0;
  const std::string unit = metres ? "mm" : fit.length_unit + "s";
  const int ro = 2 * np, to = 2 * np + 3;
  const Eigen::Vector3d rv = RotationVector(fit.right_from_left.rotation);
  const Eigen::Vector3d t = fit.right_from_left.translation;
  const char* rn[3] = {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"};
  const char* tn[3] = {"stereo.tx", "stereo.ty", "stereo.tz"};
  for (int j = 0; j < 3; ++j) {
    result->Set({rn[j],
                 rv(j) * 180 / M_PI,
                 fit.sigmas[ro + j] * 180 / M_PI,
                 "deg",
                 std::nullopt,
                 bool(fit.determined[ro + j]),
                 note_of(fit.param_names[ro + j])});
    result->Set({tn[j],
                 t(j) * f,
                 fit.sigmas[to + j] * f,
                 unit,
                 std::nullopt,
                 bool(fit.determined[to + j]),
                 note_of(fit.param_names[to + j])});
  }
  // Baseline |T| and its sigma by first-order propagation.
  const double b = t.norm();
  const Eigen::Vector3d g = t / b;
  const Eigen::Matrix3d Ct = fit.covariance.block(to, to, 3, 3);
  const bool t_ok = fit.determined[to] && fit.determined[to + 1] && fit.determined[to + 2];
  result->Set({metres ? "stereo.baseline_mm" : "stereo.baseline_" + unit,
               b * f,
               t_ok ? std::sqrt(g.dot(Ct * g)) * f : kNaN,
               unit,
               std::nullopt,
               t_ok,
               t_ok ? "" : "translation not determined"});
  if (fit.board_warp_fitted) {
    // The board's bow (fitting/board_warp.h), fitted so that it does not bias the focal lengths.
    const char* wn[2] = {"stereo.board_warp_x", "stereo.board_warp_y"};
    for (int j = 0; j < 2; ++j) {
      const bool ok = std::isfinite(fit.board_warp_sigma[j]);
      result->Set(
          {std::string(wn[j]) + (metres ? "_mm" : "_" + unit),
           fit.board_warp[j] * f,
           fit.board_warp_sigma[j] * f,
           unit,
           std::nullopt,
           ok,
           ok ? "bow of the board towards the camera across its corner grid (mrcal's model)" : "not determined"});
    }
  }
  for (const auto& u : fit.undetermined) result->warnings.push_back(u);
  if (!metres)
    result->warnings.push_back("stereo translation is in " + unit + " (target unit '" + fit.length_unit +
                               "'), not metres; result stereo covariance is in that unit");
  StereoEstimate est;
  est.right_from_left = fit.right_from_left;
  est.covariance.setZero();
  const Eigen::MatrixXd& C = fit.covariance;
  for (int a = 0; a < 6; ++a)
    for (int c = 0; c < 6; ++c) est.covariance(a, c) = C(ro + a, ro + c);
  if (metres && C.rows() == int(fit.param_names.size()) && C.cols() == C.rows()) {
    est.full_names = fit.param_names;
    est.full_covariance = C;
  }
  result->stereo = est;
  SolveSummary s = fit.summary;
  s.problem = "stereo";
  result->summaries.push_back(s);
  for (int e = 0; e < 2; ++e) {
    SolveSummary pe = fit.per_eye[e].summary;
    pe.problem = std::string("intrinsics.") + kEyeName[e] + " (initialisation)";
    result->summaries.push_back(pe);
  }
  nlohmann::json d;
  d["pairs"] = fit.paired_frames;
  d["rms_px"] = {{"left", fit.rms_px[0]}, {"right", fit.rms_px[1]}, {"joint", fit.rms_joint_px}};
  d["corner_sigma_px"] = {{"left", fit.corner_sigma_px[0]}, {"right", fit.corner_sigma_px[1]}};
  d["rectified_dy_mean_px"] = fit.rectified_dy_mean_px;
  d["rectified_dy_max_px"] = fit.rectified_dy_max_px;
  d["rectified_num_corners"] = fit.rectified_num_corners;
  d["length_unit"] = fit.length_unit;
  nlohmann::json rej = nlohmann::json::array();
  for (const auto& r : fit.rejected)
    rej.push_back({{"eye", kEyeName[r.eye == 1 ? 1 : 0]},
                   {"frame", r.frame_index},
                   {"corner", r.corner_id},
                   {"residual_px", r.residual_px}});
  d["rejected"] = rej;
  result->diagnostics["stereo"] = d;
}

}  // namespace owlcal::fitting
