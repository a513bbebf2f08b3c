// Stage 3 of the calibration: the truth in the fit's gauge and the tag study
// (pipeline/calibrate_stages.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <utility>

#include "evaluation/truth_compare.h"
#include "fitting/head_gauge.h"
#include "pipeline/calibrate_stages.h"
#include "pipeline/tag_study.h"
#include "reports/table.h"

namespace owlcal::pipeline::stages {
namespace {

// The stereo truth at the stereo capture's command and approach (backlash side).
void FillStereoTruth(const Inputs& in, fitting::CalibrationResult* result) {
  models::PwmVector pwm = in.options.config.Centre();
  std::array<int, models::kNumServos> approach{};
  const auto obs = ReadObservations(in.Dataset("stereo"));
  if (!obs.empty()) {
    pwm = obs.front().pwm_us;
    for (int s = 0; s < models::kNumServos; ++s) approach[s] = obs.front().approach[s];
  }
  evaluation::FillTruth(evaluation::StereoTruthValues(*in.options.truth, pwm, approach), result);
}

// Why the fused fit's pinhole and pan zero are floored (diagnostics.tags.floors).
std::string FloorsNote(const CalibratePipelineOptions& o) {
  return std::string("With the tags ") +
         (o.fused_pinhole_floor
              ? "the focal scale and the principal points stay as certain as the stereo fit makes them"
              : "") +
         (o.fused_pinhole_floor && o.fused_pan_zero_floor ? " and " : "") +
         (o.fused_pan_zero_floor ? "the pan zero as certain as the chessboard's fit makes it, so the pans' sigma at "
                                   "their ends, which the pan zero sets, does not shrink"
                                 : "") +
         " (the static sheets move them more than their residuals show; docs/conventions.md)";
}

// With fuse_tags off: this run's fused errors at the servo ends in its own sigmas (with the truth).
// Only what this run measured: a figure from a bench run elsewhere does not belong here.
std::string ChessboardHeadNote(const nlohmann::json& tags) {
  double z_lo = INFINITY, z_hi = 0;
  std::string worst;
  for (const auto& e : tags.value("servo_ends", nlohmann::json::array())) {
    if (!e.contains("error_with_tags_deg") || !e["error_with_tags_deg"].is_number() ||
        !(e.value("sigma_with_tags_deg", 0.0) > 0))
      continue;
    const double z = std::abs(e["error_with_tags_deg"].get<double>()) / e["sigma_with_tags_deg"].get<double>();
    z_lo = std::min(z_lo, z);
    if (z > z_hi) z_hi = z, worst = e.value("servo", std::string()) + " " + e.value("end", std::string());
  }
  return "the calibration's head is the chessboard's (fuse_tags off); the with-tags sigmas are a diagnostic" +
         (z_hi > 0
              ? std::string("; in this run (the virtual Owl's truth) the fused fit's errors at the servo ends are ") +
                    reports::Fmt(z_lo, 2) + "-" + reports::Fmt(z_hi, 2) + " of its own sigmas (worst: " + worst + ")"
              : std::string());
}

}  // namespace

void CompareWithTruth(const Inputs& in, const HeadStage& head, evaluation::CalibrationRun* run) {
  const CalibratePipelineOptions& o = in.options;
  if (!o.truth) return;
  fitting::CalibrationResult& result = run->result;
  models::HeadModel canonical = fitting::CanonicalHead(
      *o.truth, o.config.servos[models::kNeck].centre_us, head.neck_moved, head.initial.geometry.centre_in_head[0]);
  // In the fit's direction convention (models/servo_map.h: the same angles with the direction
  // and the slope, quadratic and cubic terms negated), so a robot file whose direction is wrong
  // compares the map, not the sign convention.
  for (int s = 0; s < models::kNumServos; ++s)
    if (canonical.directions[s] != head.initial.directions[s]) {
      canonical.directions[s] = head.initial.directions[s];
      for (int k = 1; k <= 3; ++k) canonical.servo_params[s][k] = -canonical.servo_params[s][k];
    }
  run->truth = canonical;
  fitting::SetHeadTruth(canonical, &result);
  evaluation::FillTruth(evaluation::IntrinsicsTruthValues(*o.truth), &result);
  FillStereoTruth(in, &result);
  // A lens fitted with another model than the truth's: by projection, not by coefficient.
  std::array<const models::CameraIntrinsics*, 2> fitted{};
  for (int e = 0; e < 2; ++e)
    fitted[e] = result.cameras[e] ? &*result.cameras[e] : (result.head ? &result.head->intrinsics[e] : nullptr);
  evaluation::CompareLensByProjection(*o.truth, fitted, {"", "head."}, &result);
}

void AddTagStudy(const Inputs& in, const HeadStage& head, evaluation::CalibrationRun* run) {
  const CalibratePipelineOptions& o = in.options;
  if (!head.with_tags || !head.with_tags->ok) return;
  nlohmann::json& tags = run->result.diagnostics["tags"];
  tags = TagStudy(head.sweep_views,
                  head.options.noise_class_of_board,
                  *head.with_tags,
                  head.without_tags,
                  o.config,
                  run->truth ? &*run->truth : nullptr);
  tags["head_result"] = o.fuse_tags ? "fused (chessboard and tags)" : "chessboard only";
  if (o.fused_pinhole_floor || o.fused_pan_zero_floor) tags["floors"] = FloorsNote(o);
  if (run->truth) {
    // Both head fits' parameters against the truth (the calibration's head is one of them), so
    // the Monte-Carlo bench scores the fused fit's sigmas as its own groups
    // (bench/robot_prior_mc_bench.cc).
    nlohmann::json fits = nlohmann::json::object();
    for (const auto& [key, fit] : {std::pair<const char*, const fitting::HeadFit*>{"fused", &*head.with_tags},
                                   {"chessboard", head.without_tags ? &*head.without_tags : nullptr}}) {
      if (!fit || !fit->ok) continue;
      fitting::CalibrationResult r;
      r.parameters = fit->result.parameters;
      fitting::SetHeadTruth(*run->truth, &r);
      fits[key] = fitting::ToJson(r)["parameters"];
    }
    tags["parameters"] = fits;
  }
  if (!o.fuse_tags) tags["note"] = ChessboardHeadNote(tags);
}

}  // namespace owlcal::pipeline::stages
