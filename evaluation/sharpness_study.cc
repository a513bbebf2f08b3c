#include "evaluation/sharpness_study.h"

#include "io/json_strict.h"
#include "models/head_kinematics.h"

namespace owlcal::evaluation {

nlohmann::json SharpnessStudyJson(const SharpnessStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["num_ok"] = s.num_ok;
  j["num_failed"] = s.num_failed;
  j["notes"] = s.notes;
  for (int e = 0; e < 2; ++e) {
    const fitting::FocusFit& f = s.fit[e];
    nlohmann::json eye;
    for (const SharpnessAtDistance& a : s.by_distance[e])
      eye["by_distance"].push_back({{"distance_m", a.distance_m},
                                    {"num_ok", a.num_ok},
                                    {"num_images", a.num_images},
                                    {"blur_sigma_px", a.num_ok ? io::JsonNumber(a.sigma_px) : nullptr},
                                    {"blur_sigma_se_px", a.num_ok ? io::JsonNumber(a.se_px) : nullptr},
                                    {"laplacian_variance", a.num_ok ? io::JsonNumber(a.laplacian_variance) : nullptr}});
    eye["fit"] = {{"ok", f.ok},
                  {"reason", f.reason},
                  {"focus_found", f.focus_found},
                  {"in_focus_blur_px", io::JsonNumber(f.s0_px)},
                  {"in_focus_blur_sigma_px", io::JsonNumber(f.s0_sigma_px)},
                  {"defocus_px_per_dioptre", io::JsonNumber(f.k_px_per_dioptre)},
                  {"defocus_sigma", io::JsonNumber(f.k_sigma)},
                  {"focus_dioptre", f.focus_found ? io::JsonNumber(f.focus_dioptre) : nullptr},
                  {"focus_dioptre_sigma", f.focus_found ? io::JsonNumber(f.focus_dioptre_sigma) : nullptr},
                  {"focus_m", f.focus_found ? io::JsonNumber(f.focus_m) : nullptr},
                  {"dof_blur_ratio", f.dof_blur_ratio},
                  {"dof_near_m", io::JsonNumber(f.dof_near_m)},
                  {"dof_near_sigma_m", io::JsonNumber(f.dof_near_sigma_m)},
                  {"dof_far_m", io::JsonNumber(f.dof_far_m)},  // null = infinity
                  {"dof_far_sigma_m", io::JsonNumber(f.dof_far_sigma_m)},
                  {"chi2_per_dof", io::JsonNumber(f.chi2_per_dof)}};
    j["eyes"][models::kEyeNames[e]] = eye;
  }
  if (s.truth) {
    j["truth"] = {{"aperture_mm", s.truth->aperture_mm},
                  {"focus_m", s.truth->focus_m},
                  {"defocus_px_per_dioptre", {s.truth->k_px_per_dioptre[0], s.truth->k_px_per_dioptre[1]}}};
  }
  return j;
}

}  // namespace owlcal::evaluation
