#include "pipeline/calibrate_pipeline.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <set>
#include <stdexcept>

#include "fitting/robot_config_json.h"
#include "models/camera_model.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/saccade_study.h"
#include "protocols/dataset.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

// A dataset of a protocol no calibration step reads is skipped, so the fit lacks what it holds (a
// renamed intrinsics dataset widens every sigma): a warning, never only a progress line.
void WarnOfUnknownDatasets(const stages::Inputs& in, fitting::CalibrationResult* result) {
  static const std::set<std::string> kKnown = {
      "intrinsics", "stereo", "servo_sweep", "vergence", "latency", "step_response", "limits", "alignment", "saccade"};
  size_t unknown = 0;  // the warnings go first, in the datasets' order, whatever ran before
  for (const auto& [name, dir] : in.datasets) {
    if (kKnown.count(name)) continue;
    std::string known;
    for (const auto& k : kKnown) {
      if (!known.empty()) known += ", ";
      known += k;
    }
    const std::string w = "dataset " + dir + " skipped: its manifest names protocol '" + name +
                          "', which no calibration step reads (known: " + known + ")";
    result->warnings.insert(result->warnings.begin() + (unknown++), w);
    if (in.options.warning)
      in.options.warning(w);
    else
      in.Progress(w);
  }
}

// What the bring-up learned and the protocols after it used: diagnostics.bring_up, and its
// findings as warnings.
void AddBringUp(const stages::Inputs& in, fitting::CalibrationResult* result) {
  if (!in.options.bring_up) return;
  result->diagnostics["bring_up"] = in.options.bring_up->ToJson();
  for (const auto& f : in.options.bring_up->findings) {
    result->warnings.push_back("robot file: " + f);
    in.Progress("bring-up: " + f);
  }
}

}  // namespace

namespace stages {

std::string Inputs::Dataset(const char* name) const {
  const auto it = datasets.find(name);
  return it == datasets.end() ? std::string() : it->second;
}

void Inputs::Progress(const std::string& line) const {
  if (options.progress) options.progress(line);
}

}  // namespace stages

// Why each value: docs/uncertainty.md (the noise model, with the figures each was chosen on).
fitting::StereoFitOptions CalibratePipelineOptions::CalibrateStereoFitOptions() {
  fitting::StereoFitOptions so;
  so.fit_board_warp = true;  // a real course board bows by about 1 mm
  // The rational lens as (1 + k1 r^2) / (1 + k4 r^2): its six radial terms trade against each other.
  so.intrinsics.rational_fix_radial = {2, 3, 5, 6};
  return so;
}

fitting::HeadFitOptions CalibratePipelineOptions::CalibrateHeadFitOptions() {
  fitting::HeadFitOptions ho;
  ho.fit_intrinsics = true;         // refined on the sweep: held, their errors bias the pan zeros
  ho.fit_board_warp = true;         // a bow fitted as flat moves focal lengths, servo scales and IPD together
  ho.estimate_corner_sigma = true;  // whiten by the noise the residuals show, per eye
  ho.measured_sigma_factor = 1.4;   // the detector bias neighbouring views share
  ho.hysteresis_sigma_floor_us = 0;
  ho.covariance_clusters = fitting::CovarianceClusters::Cell(100);  // sandwich over placement x 100 us cells
  ho.robust_sigma_factor = 1.0;
  ho.intrinsics_floor_carry = fitting::FloorCarry::kServoMaps;  // a focal-length error scales every angle the maps give
  ho.pan_zero_sigma_factor = 1.25;                              // the head-yaw gauge's eye-depth difference
  ho.rational_fix_radial = {2, 3, 5, 6};                        // the stereo fit's rational lens form
  return ho;
}

bool CalibratePipelineOptions::Check(std::string* why) const {
  if (!(fps > 0 && fps <= 1000)) {
    *why = "fps must be in (0, 1000]";
    return false;
  }
  if (default_delay_frames < 1) {
    *why = "default_delay_frames must be >= 1";
    return false;
  }
  if (!(fused_floor_scale >= 0 && fused_floor_scale <= 10)) {
    *why = "fused_floor_scale must be in [0, 10]";
    return false;
  }
  if (!(tag_sigma_factor >= 1 && tag_sigma_factor < 100)) {
    *why = "tag_sigma_factor must be in [1, 100)";
    return false;
  }
  if (!(theory_min_m > 0 && theory_max_m >= theory_min_m && theory_step_m > 0)) {
    *why = "theory distances need 0 < min <= max and step > 0";
    return false;
  }
  if (!stereo.Check(why)) return false;
  if (!lens_choice.Check(why)) return false;
  return head.Check(why);
}

nlohmann::json CalibratePipelineOptions::ToJson() const {
  const fitting::IntrinsicsFitOptions& in = stereo.intrinsics;
  nlohmann::json h = {
      {"corner_sigma_px", head.corner_sigma_px},
      {"estimate_corner_sigma", head.estimate_corner_sigma},
      {"measured_sigma_factor", head.measured_sigma_factor},
      {"min_corner_sigma_px", head.min_corner_sigma_px},
      {"hysteresis_sigma_floor_us", head.hysteresis_sigma_floor_us},
      {"covariance_clusters", head.covariance_clusters.Spec()},
      {"robust_sigma_factor", head.robust_sigma_factor},
      {"intrinsics_floor_carry", fitting::FloorCarryName(head.intrinsics_floor_carry)},
      {"pan_zero_sigma_factor", head.pan_zero_sigma_factor},
      {"view_outlier_factor", head.view_outlier_factor},
      {"noise_class_of_board", head.noise_class_of_board},
      {"tag_size_of_board", head.tag_size_of_board},
      {"fit_intrinsics", head.fit_intrinsics},
      {"fit_board_warp", head.fit_board_warp},
      {"intrinsics_prior",
       head.intrinsics_prior_covariance[0].has_value() || head.intrinsics_prior_covariance[1].has_value()},
      {"intrinsics_prior_from_stereo", head_prior_from_stereo},
      {"fit_nonlinear", head.fit_nonlinear},
      {"fit_hysteresis", head.fit_hysteresis},
      {"huber_sigma", head.huber_sigma},
      {"outlier_threshold_sigma", head.outlier_threshold_sigma},
      {"min_corners_per_view", head.min_corners_per_view},
      {"max_iterations", head.max_iterations},
      {"rank_tolerance", head.rank_tolerance},
      {"num_threads", head.num_threads}};
  nlohmann::json i = {{"model", in.model == models::DistortionModel::kOpenCv8 ? "opencv8" : "opencv5"},
                      {"fix_aspect_ratio", in.fix_aspect_ratio},
                      {"fix_principal_point", in.fix_principal_point},
                      {"fix_k3", in.fix_k3},
                      {"fix_tangential", in.fix_tangential},
                      {"corner_sigma_px", in.corner_sigma_px},
                      {"loss",
                       in.loss == fitting::RobustLoss::kHuber    ? "huber"
                       : in.loss == fitting::RobustLoss::kCauchy ? "cauchy"
                                                                 : "none"},
                      {"loss_scale_sigma", in.loss_scale_sigma},
                      {"outlier_threshold_sigma", in.outlier_threshold_sigma},
                      {"min_corners_per_view", in.min_corners_per_view},
                      {"max_iterations", in.max_iterations},
                      {"max_sigma_px", in.max_sigma_px},
                      {"max_sigma_distortion", in.max_sigma_distortion},
                      {"rank_tolerance", in.rank_tolerance}};
  nlohmann::json s = {{"intrinsics", i},
                      {"width", stereo.width},
                      {"height", stereo.height},
                      {"fix_intrinsics", stereo.fix_intrinsics},
                      {"fit_board_warp", stereo.fit_board_warp},
                      {"length_unit", stereo.length_unit},
                      {"rectify_alpha", stereo.rectify_alpha},
                      {"max_iterations", stereo.max_iterations}};
  const nlohmann::json lens = {{"enabled", lens_choice.enabled},
                               {"folds", lens_choice.folds},
                               {"min_frames", lens_choice.min_frames},
                               {"min_relative_gain", lens_choice.min_relative_gain}};
  return {{"robot", fitting::RobotConfigToJson(config)},
          {"bring_up", bring_up.has_value()},
          {"lens_choice", lens},
          {"truth", truth.has_value()},
          {"fps", fps},
          {"truth_slew_deg_per_s", truth_slew_deg_per_s},
          {"truth_latency_s", truth_latency_s},
          {"default_delay_frames", default_delay_frames},
          {"fuse_tags", fuse_tags},
          {"tag_sigma_factor", tag_sigma_factor},
          {"fused_floor_scale", fused_floor_scale},
          {"fused_pinhole_floor", fused_pinhole_floor},
          {"fused_pan_zero_floor", fused_pan_zero_floor},
          {"stereo", s},
          {"head", h},
          {"theory_distances_m", {theory_min_m, theory_max_m, theory_step_m}}};
}

bool SetLensModel(const std::string& value, CalibratePipelineOptions* o, std::string* why) {
  o->lens_choice.enabled = value == "auto";
  if (value == "opencv5" || value == "auto")
    o->stereo.intrinsics.model = models::DistortionModel::kOpenCv5;
  else if (value == "opencv8")
    o->stereo.intrinsics.model = models::DistortionModel::kOpenCv8;
  else {
    if (why) *why = "--lens-model = '" + value + "': use auto, opencv5 or opencv8";
    return false;
  }
  return true;
}

const std::set<std::string>& GeometryDatasetNames() {
  static const std::set<std::string> kNames = {"limits", "intrinsics", "stereo", "servo_sweep"};
  return kNames;
}

evaluation::CalibrationRun FitGeometry(const std::map<std::string, std::string>& datasets,
                                       const CalibratePipelineOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("calibrate pipeline options: " + why);
  const stages::Inputs in{datasets, o};
  evaluation::CalibrationRun run;
  run.config = o.config;
  AddBringUp(in, &run.result);
  const std::optional<fitting::StereoFit> stereo = stages::FitLensAndStereo(in, &run);
  const stages::HeadStage head = stages::FitHeadFromSweep(in, stereo, &run);
  stages::CompareWithTruth(in, head, &run);
  stages::AddTagStudy(in, head, &run);
  return run;
}

void FitEvaluations(const std::map<std::string, std::string>& datasets,
                    const CalibratePipelineOptions& o,
                    evaluation::CalibrationRun* run) {
  const stages::Inputs in{datasets, o};
  WarnOfUnknownDatasets(in, &run->result);
  stages::EvaluateResolutionAndRanging(in, run);
  stages::EvaluateSteps(in, run);
}

evaluation::CalibrationRun FitCalibration(const std::map<std::string, std::string>& datasets,
                                          const CalibratePipelineOptions& o) {
  evaluation::CalibrationRun run = FitGeometry(datasets, o);
  FitEvaluations(datasets, o, &run);
  return run;
}

void FinishCalibration(const std::map<std::string, std::string>& datasets,
                       const CalibratePipelineOptions& o,
                       evaluation::CalibrationRun* run) {
  const stages::Inputs in{datasets, o};
  if (const std::string saccade = in.Dataset("saccade"); !saccade.empty()) AddSaccadeEvaluation(saccade, o, run);
  stages::EvaluateLimits(in, run);
  stages::AddReferenceChecks(in, run);
  run->result.inputs["datasets"] = datasets;
  run->result.inputs["pipeline"] = o.ToJson();
}

evaluation::CalibrationRun CalibrateFromDatasets(const std::map<std::string, std::string>& datasets,
                                                 const CalibratePipelineOptions& o) {
  evaluation::CalibrationRun d = FitCalibration(datasets, o);
  FinishCalibration(datasets, o, &d);
  return d;
}

std::map<std::string, std::string> FindDatasets(const std::string& calibration_dir) {
  const fs::path root = fs::path(calibration_dir) / "datasets";
  if (!fs::is_directory(root)) throw NoDatasetsError(root.string() + ": missing (not a calibrate output folder)");
  std::vector<fs::path> dirs;
  for (const auto& e : fs::directory_iterator(root))
    if (e.is_directory() && fs::exists(e.path() / "manifest.json")) dirs.push_back(e.path());
  std::sort(dirs.begin(), dirs.end());
  std::map<std::string, std::string> out;
  for (const fs::path& dir : dirs) {
    const nlohmann::json m = protocols::ReadManifest(dir.string());
    const std::string where = (dir / "manifest.json").string();
    if (!m.contains("protocols") || !m["protocols"].is_array() || m["protocols"].size() != 1 ||
        !m["protocols"][0].contains("name") || !m["protocols"][0]["name"].is_string())
      throw NoDatasetsError(where + ": field 'protocols' does not hold exactly one protocol with a name");
    const std::string name = m["protocols"][0]["name"].get<std::string>();
    // calibrate names each dataset folder after its protocol file: keep that path, so a re-fit
    // records the same inputs.
    const std::string path = (fs::path(calibration_dir) / "datasets" / dir.filename()).string();
    if (!out.emplace(name, path).second)
      throw NoDatasetsError(where + ": a second dataset of protocol '" + name + "' (the first: " + out[name] + ")");
  }
  if (out.empty()) throw NoDatasetsError(root.string() + ": holds no dataset (no */manifest.json)");
  return out;
}

models::RobotConfig RobotConfigFromManifest(const nlohmann::json& manifest, const std::string& path) {
  if (!manifest.contains("robot") || !manifest["robot"].is_object() || !manifest["robot"].contains("config"))
    throw std::runtime_error(path + ": field 'robot.config' is missing");
  try {
    return fitting::RobotConfigFromJson(manifest["robot"]["config"]);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": field 'robot.config': " + e.what());
  }
}

}  // namespace owlcal::pipeline
