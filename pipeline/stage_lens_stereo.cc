// Stage 1 of the calibration: intrinsics and stereo (pipeline/calibrate_stages.h).
#include <filesystem>
#include <string>
#include <vector>

#include "calib/observation_io.h"
#include "evaluation/fit_points.h"
#include "evaluation/stereo_sanity.h"
#include "fitting/lens_model_choice.h"
#include "pipeline/calibrate_stages.h"
#include "reports/table.h"

namespace owlcal::pipeline::stages {
namespace {

void SplitEyes(const std::vector<calib::View>& views, std::vector<calib::View>* l, std::vector<calib::View>* r) {
  for (const auto& v : views) (v.eye == models::kLeftEye ? l : r)->push_back(v);
}

// The report's name of a calibration view (frame numbers as offset in FitLensAndStereo).
std::string ViewName(int frame, int /*eye*/) {
  if (frame >= 2000000) return "intrinsics frame " + std::to_string(frame - 2000000);
  if (frame >= 1000000) return "stereo frame " + std::to_string(frame - 1000000);
  return "intrinsics frame " + std::to_string(frame);
}

// The physical sanity of the fitted rig against this robot (evaluation/stereo_sanity.h): a mirrored
// or swapped stream setting shows as T_x > 0, and is named with the robot-file field to change.
void CheckRig(const Inputs& in, const fitting::StereoFit& stereo, fitting::CalibrationResult* result) {
  evaluation::RigExpectation rig = evaluation::RigExpectation::Owl();
  rig.ipd_m = in.options.config.ipd_m;
  const evaluation::StereoSanity sanity =
      evaluation::CheckStereoSanity(stereo.cameras, stereo.right_from_left, 1.0, rig);
  evaluation::AppendSanityToResult(sanity, rig, result);
  for (const auto& f : sanity.findings)
    in.Progress("  sanity (" + std::string(f.unusable ? "unusable" : "poor") + "): " + f.message +
                (f.check == "tx_sign" ? " [robot file: image.mirror / image.swap_eyes]" : ""));
}

}  // namespace

std::vector<calib::CornerObservation> ReadObservations(const std::string& dataset) {
  const std::string p = dataset + "/observations.csv";
  if (dataset.empty() || !std::filesystem::exists(p)) return {};
  return calib::ReadObservationsCsv(p);
}

std::optional<fitting::StereoFit> FitLensAndStereo(const Inputs& in, evaluation::CalibrationRun* run) {
  using reports::Fmt;
  const CalibratePipelineOptions& o = in.options;
  fitting::CalibrationResult& result = run->result;
  // The intrinsics capture moves the eyes, so its left/right frames do not share one
  // right_from_left: keep them unpaired (they constrain each eye's intrinsics only). Only the
  // stereo capture, taken at one fixed eye pose, pairs left with right.
  std::vector<calib::CornerObservation> obs = ReadObservations(in.Dataset("intrinsics"));
  for (auto& c : obs)
    if (c.eye == models::kRightEye) c.frame_index += 2000000;
  for (auto c : ReadObservations(in.Dataset("stereo"))) {
    c.frame_index += 1000000;  // keep frames of the two datasets apart
    obs.push_back(c);
  }
  const std::vector<calib::View> views = calib::GroupIntoViews(obs);
  std::vector<calib::View> l, r;
  SplitEyes(views, &l, &r);
  in.Progress("stereo fit: " + std::to_string(l.size()) + " left and " + std::to_string(r.size()) + " right views");
  if (l.empty() || r.empty()) {
    result.warnings.push_back("no chessboard views: intrinsics and stereo not fitted");
    return std::nullopt;
  }
  std::optional<fitting::StereoFit> stereo;
  std::optional<fitting::LensModelChoice> lens;
  if (o.lens_choice.enabled) {
    // The lens model by cross-validation; the chosen model's fit on all views is the fit.
    lens = fitting::ChooseStereoLensModel(l, r, o.stereo, o.lens_choice);
    in.Progress("  lens model: " + lens->reason + " [" + Fmt(lens->time_s, 3) + " s]");
    if (const fitting::LensModelScore* s = lens->Score(lens->chosen)) stereo = s->full;
  }
  if (!stereo) {
    fitting::StereoFitOptions so = o.stereo;
    so.intrinsics = fitting::WithModel(so.intrinsics, lens ? lens->chosen : so.intrinsics.model);
    stereo = fitting::FitStereo(l, r, so);
  }
  if (lens) fitting::AppendLensModelChoiceToResult(*lens, &result);
  if (!stereo->ok) {
    result.warnings.push_back("stereo fit failed: " + stereo->message);
    in.Progress("  failed: " + stereo->message);
    return stereo;
  }
  fitting::AppendStereoToResult(*stereo, &result);
  CheckRig(in, *stereo, &result);
  evaluation::AddFitPoints(*stereo, views, ViewName, run);
  in.Progress("  RMS " + Fmt(stereo->rms_px[0], 3) + " / " + Fmt(stereo->rms_px[1], 3) + " px");
  return stereo;
}

}  // namespace owlcal::pipeline::stages
