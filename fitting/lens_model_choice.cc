// The lens model chosen by cross-validation over frames (fitting/lens_model_choice.h): the
// shared driver over the two candidates and the decision, for a stereo pair and for one camera,
// and the choice's results.json entries. The folds: fitting/frame_cross_validation.cc; the board
// bow's choice: fitting/board_warp_choice.cc.
#include "fitting/lens_model_choice.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <sstream>

#include "fitting/format.h"
#include "fitting/frame_cross_validation.h"

namespace owlcal::fitting {
namespace {

using models::DistortionModel;

constexpr DistortionModel kCandidates[2] = {DistortionModel::kOpenCv5, DistortionModel::kOpenCv8};

// The choice from the two scores; fills gain, its standard error and the reason.
void Decide(const std::map<int, internal::FrameError> per_frame[2],
            const LensModelChoiceOptions& o,
            LensModelChoice* c) {
  const LensModelScore& s5 = c->scores[0];
  const LensModelScore& s8 = c->scores[1];
  c->gain_px = s5.heldout_rms_px - s8.heldout_rms_px;
  c->gain_se_px = internal::GainStandardError(per_frame, s5.heldout_rms_px, s8.heldout_rms_px);
  const bool gains = s8.heldout_rms_px < s5.heldout_rms_px * (1 - o.min_relative_gain);
  // More than noise: the gain must exceed twice its standard error (from the per-frame
  // differences). On 8 stereo views of robots of the prior (5-coefficient lenses) the rational
  // model had won on 12 of 30 robots by a gain of 1.0 standard error (one frame's extrapolation),
  // with k1 k2 k4 k5 undetermined and k3 "determined" up to 68 sigma from the truth.
  // Or better on most frames (sign test, two standard deviations): a wide lens's edge frames,
  // where the 5-coefficient model fails by a pixel, make the standard error large.
  internal::CountFramesBetter(per_frame, &c->frames_better, &c->frames_compared);
  const bool significant =
      internal::HeldOutGainSignificant(c->gain_px, c->gain_se_px, c->frames_better, c->frames_compared);
  const bool richer = gains && significant;
  c->chosen = richer ? DistortionModel::kOpenCv8 : DistortionModel::kOpenCv5;
  c->chosen_name = DistortionModelName(c->chosen);
  std::ostringstream r;
  r << c->chosen_name << " chosen by " << c->folds << "-fold cross-validation over " << c->num_frames
    << " frames: held-out RMS opencv5 " << FixedOrDash(s5.heldout_rms_px, 4) << " px, opencv8 "
    << FixedOrDash(s8.heldout_rms_px, 4) << " px (difference " << FixedOrDash(c->gain_px, 4) << " +- "
    << FixedOrDash(c->gain_se_px, 4) << " px; fit RMS " << FixedOrDash(s5.fit_rms_px, 4) << " / "
    << FixedOrDash(s8.fit_rms_px, 4) << " px; opencv8 better on " << c->frames_better << " of " << c->frames_compared
    << " frames)";
  if (s8.heldout_rms_px >= s5.heldout_rms_px)
    r << "; the rational model predicts held-out views no better";
  else if (!gains)
    r << "; the rational model's gain is below the " + FixedOrDash(100 * o.min_relative_gain, 2) +
             " % a richer model must earn";
  else if (!significant)
    r << "; the rational model's gain is within twice its standard error and it is not better on most frames";
  c->reason = r.str();
}

// Shared driver: `train(model, views)` returns a Trained; `full(model, score)` fits all views.
template <typename TrainFn, typename FullFn>
LensModelChoice Choose(const std::vector<calib::View>* views[2],
                       DistortionModel configured,
                       const LensModelChoiceOptions& o,
                       TrainFn train,
                       FullFn full) {
  const auto t0 = std::chrono::steady_clock::now();
  LensModelChoice c;
  c.chosen = configured;
  c.chosen_name = DistortionModelName(configured);
  std::string why;
  const std::vector<int> frames = internal::FramesOf(views);
  c.num_frames = int(frames.size());
  if (!o.Check(&why)) {
    c.reason = "lens model not chosen (" + why + "): " + c.chosen_name + " as configured";
  } else if (!o.enabled) {
    c.reason = c.chosen_name + " as configured (cross-validation off)";
  } else if (c.num_frames < o.min_frames) {
    c.reason = c.chosen_name + " as configured: " + std::to_string(c.num_frames) +
               " frames are too few to cross-validate (at least " + std::to_string(o.min_frames) + ")";
  } else {
    c.folds = std::min(o.folds, c.num_frames);
    std::map<int, internal::FrameError> per_frame[2];
    for (int m = 0; m < 2; ++m) {
      LensModelScore s;
      s.model = kCandidates[m];
      s.name = DistortionModelName(s.model);
      internal::CrossValidate(
          views,
          frames,
          c.folds,
          [&](const std::vector<calib::View>* tv) { return train(s.model, tv); },
          &s,
          &per_frame[m]);
      full(&s);
      c.scores.push_back(std::move(s));
    }
    std::string failed;
    for (const auto& s : c.scores) {
      if (s.ok) continue;
      if (!failed.empty()) failed += "; ";
      failed += s.name + ": " + s.message;
    }
    if (failed.empty()) {
      c.cross_validated = true;
      Decide(per_frame, o, &c);
    } else {
      c.reason = c.chosen_name + " as configured: cross-validation failed (" + failed + ")";
    }
  }
  c.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

}  // namespace
bool LensModelChoiceOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "LensModelChoiceOptions." + m;
    return false;
  };
  if (folds < 2) return fail("folds must be >= 2, got " + std::to_string(folds));
  if (min_frames < folds) return fail("min_frames must be >= folds, got " + std::to_string(min_frames));
  if (!(min_relative_gain >= 0 && min_relative_gain < 0.5))
    return fail("min_relative_gain must be in [0, 0.5), got " + FixedOrDash(min_relative_gain, 4));
  return true;
}

const LensModelScore* LensModelChoice::Score(models::DistortionModel m) const {
  for (const auto& s : scores)
    if (s.model == m) return &s;
  return nullptr;
}

std::string DistortionModelName(models::DistortionModel m) {
  return m == DistortionModel::kOpenCv8 ? "opencv8" : "opencv5";
}

LensModelChoice ChooseStereoLensModel(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& choice) {
  const std::vector<calib::View>* views[2] = {&left_views, &right_views};
  auto opts = [&](DistortionModel m, bool covariance) {
    StereoFitOptions so = options;
    so.intrinsics = WithModel(so.intrinsics, m);
    so.intrinsics.compute_covariance = covariance;
    if (!covariance) so.intrinsics.solver_tolerance = internal::kRefitTolerance;
    return so;
  };
  auto train = [&](DistortionModel m, const std::vector<calib::View>* tv) {
    return internal::TrainedOf(FitStereo(tv[0], tv[1], opts(m, false)));
  };
  auto full = [&](LensModelScore* s) {
    s->full = FitStereo(left_views, right_views, opts(s->model, options.intrinsics.compute_covariance));
    if (!s->full.ok) {
      s->ok = false;
      s->message = "fit on all views failed: " + s->full.message;
    }
    s->fit_rms_px = s->full.rms_joint_px;
  };
  return Choose(views, options.intrinsics.model, choice, train, full);
}

LensModelChoice ChooseIntrinsicsLensModel(const std::vector<calib::View>& views_in,
                                          int width,
                                          int height,
                                          const IntrinsicsFitOptions& options,
                                          const LensModelChoiceOptions& choice) {
  const std::vector<calib::View> none;
  const std::vector<calib::View>* views[2] = {&views_in, &none};
  auto opts = [&](DistortionModel m, bool covariance) {
    IntrinsicsFitOptions io = WithModel(options, m);
    io.compute_covariance = covariance;
    if (!covariance) io.solver_tolerance = internal::kRefitTolerance;
    return io;
  };
  auto train = [&](DistortionModel m, const std::vector<calib::View>* tv) {
    internal::Trained t;
    const IntrinsicsFit f = FitIntrinsics(tv[0], width, height, opts(m, false));
    t.ok = f.ok;
    t.message = f.message;
    t.cams[0] = t.cams[1] = f.camera;
    return t;
  };
  auto full = [&](LensModelScore* s) {
    s->full_intrinsics = FitIntrinsics(views_in, width, height, opts(s->model, options.compute_covariance));
    if (!s->full_intrinsics.ok) {
      s->ok = false;
      s->message = "fit on all views failed: " + s->full_intrinsics.message;
    }
    s->fit_rms_px = s->full_intrinsics.rms_px;
  };
  return Choose(views, options.model, choice, train, full);
}
nlohmann::json LensModelChoiceToJson(const LensModelChoice& c) {
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& s : c.scores)
    cands.push_back({{"model", s.name},
                     {"ok", s.ok},
                     {"message", s.message},
                     {"fit_rms_px", s.fit_rms_px},
                     {"heldout_rms_px", s.heldout_rms_px},
                     {"heldout_rms_left_px", s.heldout_rms_eye_px[0]},
                     {"heldout_rms_right_px", s.heldout_rms_eye_px[1]},
                     {"fold_rms_px", s.fold_rms_px},
                     {"num_heldout_corners", s.num_heldout_corners}});
  return {{"cross_validated", c.cross_validated},
          {"chosen", c.chosen_name},
          {"reason", c.reason},
          {"folds", c.folds},
          {"num_frames", c.num_frames},
          {"gain_px", c.gain_px},
          {"gain_se_px", std::isfinite(c.gain_se_px) ? nlohmann::json(c.gain_se_px) : nlohmann::json()},
          {"frames_better", c.frames_better},
          {"frames_compared", c.frames_compared},
          {"candidates", cands}};
}

void AppendLensModelChoiceToResult(const LensModelChoice& c, CalibrationResult* result) {
  result->diagnostics["lens_model_choice"] = LensModelChoiceToJson(c);
  result->inputs["lens_model"] = (c.cross_validated ? "auto: " : "") + c.reason;
}

}  // namespace owlcal::fitting
