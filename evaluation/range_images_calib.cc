#include "evaluation/range_images_calib.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <set>
#include <sstream>

#include <Eigen/Geometry>

#include "fitting/format.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {

void MarkUndetermined(fitting::CalibrationResult* r, const std::string& name, const std::string& why) {
  for (auto& p : r->parameters) {
    if (p.name != name) continue;
    p.determined = false;
    p.sigma = kNaN;
    p.note = why;
  }
}

}  // namespace

std::vector<std::pair<int, double>> ViewTilts(const fitting::StereoFit& fit, int eye) {
  std::vector<std::pair<int, double>> out;
  const fitting::IntrinsicsFit& f = fit.per_eye[eye];
  for (size_t i = 0; i < f.cam_from_target.size() && i < f.frame_indices.size(); ++i) {
    const Eigen::Vector3d n = f.cam_from_target[i].rotation * Eigen::Vector3d::UnitZ();
    out.push_back({f.frame_indices[i], std::acos(std::clamp(std::abs(n.z()), 0.0, 1.0)) * 180 / M_PI});
  }
  return out;
}

ImageSetCalibration CalibrateImageSet(const std::vector<calib::CornerObservation>& observations,
                                      const fitting::StereoFitOptions& options_in,
                                      const SetVerdictOptions& vo,
                                      const fitting::LensModelChoiceOptions& lens,
                                      const fitting::LensModelChoiceOptions& warp) {
  ImageSetCalibration c;
  std::vector<calib::View> views[2];
  for (const auto& v : calib::GroupIntoViews(observations)) views[v.eye == 0 ? 0 : 1].push_back(v);
  fitting::StereoFitOptions options = options_in;
  if (lens.enabled) {
    // The chosen model's fit on all views is the fit (same options, covariance included).
    c.lens_choice = fitting::ChooseStereoLensModel(views[0], views[1], options, lens);
    options.intrinsics.model = c.lens_choice->chosen;
    const fitting::LensModelScore* s = c.lens_choice->Score(c.lens_choice->chosen);
    c.fit = s ? s->full : fitting::FitStereo(views[0], views[1], options);
  } else {
    c.fit = fitting::FitStereo(views[0], views[1], options);
  }
  if (warp.enabled) {
    // The board's bow by cross-validation with the chosen lens model; the chosen setting's fit
    // on all views is the fit (and the verdict's refits below use that setting).
    c.warp_choice = fitting::ChooseStereoBoardWarp(views[0], views[1], options, warp);
    if (const fitting::LensModelScore* s = c.warp_choice->Chosen()) {
      options.fit_board_warp = c.warp_choice->bowed;
      c.fit = s->full;
    }
  }
  if (c.fit.ok) fitting::AppendStereoToResult(c.fit, &c.result);
  if (c.lens_choice) fitting::AppendLensModelChoiceToResult(*c.lens_choice, &c.result);
  if (c.warp_choice) fitting::AppendBoardWarpChoiceToResult(*c.warp_choice, &c.result);
  c.result.inputs["num_observations"] = observations.size();

  // Coverage per eye.
  const double cx = (options.width - 1) / 2.0, cy = (options.height - 1) / 2.0;
  const double half_diag = std::hypot(cx, cy);
  for (int e = 0; e < 2; ++e) {
    EyeCoverage& cov = c.coverage[e];
    std::set<int> cells;
    for (const auto& v : views[e]) {
      for (const auto& px : v.pixels) {
        const int gx = std::clamp(static_cast<int>(px.x() / options.width * 8), 0, 7);
        const int gy = std::clamp(static_cast<int>(px.y() / options.height * 6), 0, 5);
        cells.insert(gy * 8 + gx);
        cov.max_radius_fraction = std::max(cov.max_radius_fraction, std::hypot(px.x() - cx, px.y() - cy) / half_diag);
      }
    }
    cov.grid_fraction = cells.size() / 48.0;
    const fitting::IntrinsicsFit& f = c.fit.per_eye[e];
    for (const auto& [frame, tilt] : ViewTilts(c.fit, e)) {
      cov.frames.push_back(frame);
      cov.tilt_deg.push_back(tilt);
      cov.max_tilt_deg = std::max(cov.max_tilt_deg, tilt);
    }
    for (size_t i = 0; i < f.cam_from_target.size(); ++i) {
      for (size_t j = i + 1; j < f.cam_from_target.size(); ++j) {
        const Eigen::Vector3d a = f.cam_from_target[i].rotation * Eigen::Vector3d::UnitZ();
        const Eigen::Vector3d b = f.cam_from_target[j].rotation * Eigen::Vector3d::UnitZ();
        cov.spread_deg = std::max(cov.spread_deg, std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180 / M_PI);
      }
    }
  }

  // Verdict: from what the set leaves uncertain (evaluation/set_verdict.h).
  const double unit_m = options.length_unit == "m" ? 1.0 : (options.length_unit == "mm" ? 0.001 : 0.0);
  c.set_verdict = JudgeStereoSet(c.fit, views, options, unit_m, vo);
  c.poor = c.set_verdict.status != "good";
  c.verdict = c.set_verdict.reasons;
  AppendVerdictToResult(c.set_verdict, &c.result);
  // An unusable set's numbers are refused, not printed as if they were good.
  if (c.set_verdict.status == "unusable" && !c.set_verdict.reasons.empty())
    for (auto& p : c.result.parameters)
      MarkUndetermined(&c.result, p.name, "set unusable: " + c.set_verdict.reasons[0]);
  const char* eye_name[2] = {"left", "right"};

  // Diagnostics: per-view residuals and coverage.
  nlohmann::json d = nlohmann::json::object();
  for (int e = 0; e < 2; ++e) {
    const fitting::IntrinsicsFit& f = c.fit.per_eye[e];
    nlohmann::json views_j = nlohmann::json::array();
    for (size_t i = 0; i < f.frame_indices.size(); ++i) {
      views_j.push_back({{"frame", f.frame_indices[i]},
                         {"rms_px", i < f.view_rms_px.size() ? f.view_rms_px[i] : kNaN},
                         {"tilt_deg", i < c.coverage[e].tilt_deg.size() ? c.coverage[e].tilt_deg[i] : kNaN}});
    }
    d[eye_name[e]] = {{"views", views_j},
                      {"grid_coverage", c.coverage[e].grid_fraction},
                      {"max_radius_fraction", c.coverage[e].max_radius_fraction},
                      {"max_tilt_deg", c.coverage[e].max_tilt_deg},
                      {"orientation_spread_deg", c.coverage[e].spread_deg}};
  }
  c.result.diagnostics["image_set"] = d;
  return c;
}

}  // namespace owlcal::evaluation
