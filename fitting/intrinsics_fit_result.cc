// AppendIntrinsicsToResult (fitting/intrinsics_fit.h): an intrinsics fit as named parameters of
// a result.
#include "fitting/intrinsics_fit.h"

#include <limits>
#include <string>

#include "models/units.h"

namespace owlcal::fitting {
namespace {}  // namespace

void AppendIntrinsicsToResult(const IntrinsicsFit& fit, const std::string& eye_name, CalibrationResult* result) {
  SolveSummary s = fit.summary;
  s.problem = "intrinsics." + eye_name;
  result->summaries.push_back(s);
  if (!fit.ok) {
    result->warnings.push_back(eye_name + " intrinsics: " + fit.message);
    for (const auto& u : fit.undetermined) {
      const std::string name = u.substr(0, u.find(':'));
      Parameter p{
          eye_name + "." + name, kNaN, kNaN, IntrinsicParamUnit(name), std::nullopt, false, u.substr(u.find(':') + 2)};
      result->Set(p);
    }
    return;
  }
  const int eye = eye_name == "right" ? 1 : 0;
  result->cameras[eye] = fit.camera;
  for (size_t i = 0; i < fit.param_names.size(); ++i) {
    Parameter p;
    p.name = eye_name + "." + fit.param_names[i];
    p.value = fit.camera.params[i];
    p.sigma = fit.sigmas[i];
    p.unit = IntrinsicParamUnit(fit.param_names[i]);
    p.determined = fit.determined[i];
    for (const auto& u : fit.undetermined)
      if (u.rfind(fit.param_names[i] + ":", 0) == 0) p.note = u.substr(fit.param_names[i].size() + 2);
    p.held = !p.determined && internal::IsHeldReason(p.note);
    if (p.held) p.sigma = 0;
    result->Set(p);
  }
  for (const auto& u : fit.undetermined) result->warnings.push_back(eye_name + "." + u);
  nlohmann::json d;
  d["rms_px"] = fit.rms_px;
  d["corner_sigma_px"] = fit.corner_sigma_px;
  d["frames"] = fit.frame_indices;
  d["view_rms_px"] = fit.view_rms_px;
  d["dropped_views"] = fit.dropped_views;
  nlohmann::json rej = nlohmann::json::array();
  for (const auto& r : fit.rejected)
    rej.push_back({{"frame", r.frame_index}, {"corner", r.corner_id}, {"residual_px", r.residual_px}});
  d["rejected"] = rej;
  result->diagnostics["intrinsics"][eye_name] = d;
}

}  // namespace owlcal::fitting
