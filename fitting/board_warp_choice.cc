// The board's bow chosen by cross-validation over frames (ChooseStereoBoardWarp,
// fitting/lens_model_choice.h): flat against bowed, the bow and the share of the residual it
// explains, and its results.json entries.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "fitting/format.h"
#include "fitting/frame_cross_validation.h"
#include "fitting/lens_model_choice.h"

namespace owlcal::fitting {

BoardWarpChoice ChooseStereoBoardWarp(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<calib::View>* views[2] = {&left_views, &right_views};
  BoardWarpChoice c;
  c.bowed = options.fit_board_warp;
  const std::vector<int> frames = internal::FramesOf(views);
  c.num_frames = int(frames.size());
  const std::string configured = c.bowed ? "bowed" : "flat";
  std::string why;
  auto opts = [&](bool bowed, bool covariance) {
    StereoFitOptions so = options;
    so.fit_board_warp = bowed;
    so.intrinsics.compute_covariance = covariance;
    if (!covariance) so.intrinsics.solver_tolerance = internal::kRefitTolerance;
    return so;
  };
  if (!o.Check(&why)) {
    c.reason = "board warp not chosen (" + why + "): " + configured + " as configured";
  } else if (!o.enabled) {
    c.reason = configured + " board as configured (cross-validation off)";
  } else if (c.num_frames < o.min_frames) {
    c.reason = configured + " board as configured: " + std::to_string(c.num_frames) +
               " frames are too few to cross-validate (at least " + std::to_string(o.min_frames) + ")";
  } else {
    c.folds = std::min(o.folds, c.num_frames);
    std::map<int, internal::FrameError> per_frame[2];
    for (int bowed = 0; bowed < 2; ++bowed) {
      LensModelScore s;
      s.model = options.intrinsics.model;
      s.name = bowed ? "bowed" : "flat";
      internal::CrossValidate(
          views,
          frames,
          c.folds,
          [&](const std::vector<calib::View>* tv) {
            return internal::TrainedOf(FitStereo(tv[0], tv[1], opts(bowed, false)));
          },
          &s,
          &per_frame[bowed]);
      s.full = FitStereo(left_views, right_views, opts(bowed, options.intrinsics.compute_covariance));
      if (!s.full.ok) {
        s.ok = false;
        s.message = "fit on all views failed: " + s.full.message;
      }
      s.fit_rms_px = s.full.rms_joint_px;
      c.scores.push_back(std::move(s));
    }
    std::string failed;
    for (const auto& s : c.scores)
      if (!s.ok) failed += (failed.empty() ? "" : "; ") + s.name + ": " + s.message;
    if (!failed.empty()) {
      c.reason = configured + " board as configured: cross-validation failed (" + failed + ")";
    } else {
      c.cross_validated = true;
      const LensModelScore& flat = c.scores[0];
      const LensModelScore& bow = c.scores[1];
      c.gain_px = flat.heldout_rms_px - bow.heldout_rms_px;
      c.gain_se_px = internal::GainStandardError(per_frame, flat.heldout_rms_px, bow.heldout_rms_px);
      const bool gains = bow.heldout_rms_px < flat.heldout_rms_px * (1 - o.min_relative_gain);
      internal::CountFramesBetter(per_frame, &c.frames_better, &c.frames_compared);
      const bool significant =
          internal::HeldOutGainSignificant(c.gain_px, c.gain_se_px, c.frames_better, c.frames_compared);
      c.bowed = gains && significant;
      for (int j = 0; j < 2; ++j) {
        c.warp[j] = bow.full.board_warp[j];
        c.warp_sigma[j] = bow.full.board_warp_sigma[j];
      }
      c.explained_fraction =
          1 - (bow.fit_rms_px * bow.fit_rms_px) / std::max(1e-300, flat.fit_rms_px * flat.fit_rms_px);
      c.heldout_explained_fraction =
          1 - (bow.heldout_rms_px * bow.heldout_rms_px) / std::max(1e-300, flat.heldout_rms_px * flat.heldout_rms_px);
      // The bow in mm for a metric target, else in the target's unit.
      const bool metres = options.length_unit == "m";
      const double scale = metres ? 1e3 : 1.0;
      const std::string unit = metres ? "mm" : options.length_unit;
      std::ostringstream r;
      r << (c.bowed ? "bowed" : "flat") << " board chosen by " << c.folds << "-fold cross-validation over "
        << c.num_frames << " frames: held-out RMS flat " << FixedOrDash(flat.heldout_rms_px, 4) << " px, bowed "
        << FixedOrDash(bow.heldout_rms_px, 4) << " px (difference " << FixedOrDash(c.gain_px, 4) << " +- "
        << FixedOrDash(c.gain_se_px, 4) << " px; fit RMS " << FixedOrDash(flat.fit_rms_px, 4) << " / "
        << FixedOrDash(bow.fit_rms_px, 4) << " px; bowed better on " << c.frames_better << " of " << c.frames_compared
        << " frames); bow x " << FixedOrDash(scale * c.warp[0], 3) << " +- " << FixedOrDash(scale * c.warp_sigma[0], 3)
        << ", y " << FixedOrDash(scale * c.warp[1], 3) << " +- " << FixedOrDash(scale * c.warp_sigma[1], 3) << " "
        << unit << ", explaining " << FixedOrDash(100 * c.explained_fraction, 3)
        << " % of the flat fit's squared residual (" << FixedOrDash(100 * c.heldout_explained_fraction, 3)
        << " % held out)";
      if (bow.heldout_rms_px >= flat.heldout_rms_px)
        r << "; the bow predicts held-out views no better";
      else if (!gains)
        r << "; the bow's gain is below the " + FixedOrDash(100 * o.min_relative_gain, 2) +
                 " % a richer model must earn";
      else if (!significant)
        r << "; the bow's gain is within twice its standard error and it is not better on most frames";
      c.reason = r.str();
    }
  }
  c.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

const LensModelScore* BoardWarpChoice::Chosen() const {
  if (!cross_validated || scores.size() != 2) return nullptr;
  return &scores[bowed ? 1 : 0];
}

nlohmann::json BoardWarpChoiceToJson(const BoardWarpChoice& c) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& s : c.scores)
    cands.push_back({{"board", s.name},
                     {"ok", s.ok},
                     {"message", s.message},
                     {"fit_rms_px", num(s.fit_rms_px)},
                     {"heldout_rms_px", num(s.heldout_rms_px)},
                     {"heldout_rms_left_px", num(s.heldout_rms_eye_px[0])},
                     {"heldout_rms_right_px", num(s.heldout_rms_eye_px[1])},
                     {"fold_rms_px", s.fold_rms_px},
                     {"num_heldout_corners", s.num_heldout_corners}});
  return {{"cross_validated", c.cross_validated},
          {"chosen", c.bowed ? "bowed" : "flat"},
          {"reason", c.reason},
          {"folds", c.folds},
          {"num_frames", c.num_frames},
          {"gain_px", num(c.gain_px)},
          {"gain_se_px", num(c.gain_se_px)},
          {"frames_better", c.frames_better},
          {"frames_compared", c.frames_compared},
          {"warp", {num(c.warp[0]), num(c.warp[1])}},
          {"warp_sigma", {num(c.warp_sigma[0]), num(c.warp_sigma[1])}},
          {"explained_fraction", num(c.explained_fraction)},
          {"heldout_explained_fraction", num(c.heldout_explained_fraction)},
          {"candidates", cands}};
}

void AppendBoardWarpChoiceToResult(const BoardWarpChoice& c, CalibrationResult* result) {
  result->diagnostics["board_warp_choice"] = BoardWarpChoiceToJson(c);
  result->inputs["board_warp"] = (c.cross_validated ? "auto: " : "") + c.reason;
}

}  // namespace owlcal::fitting
