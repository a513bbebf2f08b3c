#pragma once
// Choosing the lens model by cross-validation over views.
//
// A richer lens model always fits the views it was fitted to at least as well; whether it
// describes the lens better shows only on views it has not seen (mrcal's argument for richer
// models, and its caution about overfitting). So each candidate model (OpenCV 5-coefficient
// k1 k2 p1 p2 k3, and the rational 8-coefficient model with k4 k5 k6) is judged by k-fold
// cross-validation over frames:
//   1. the frames (a stereo pair counts as one frame: both eyes are held out together) are
//      sorted by frame index and dealt into `folds` folds (frame i of the sorted list goes to
//      fold i mod folds), so every fold samples the whole capture;
//   2. for each fold, the fit (FitStereo, or FitIntrinsics for one camera) runs on the other
//      folds' views, without covariance;
//   3. each held-out frame is then placed by its own board pose only (6 parameters, Ceres,
//      the trained cameras and right_from_left held fixed; a pair's two eyes share one pose, so
//      the held-out error also tests the extrinsics), and its corners' pixel errors are pooled;
//   4. held-out RMS = sqrt(sum |e|^2 / corners) over every held-out corner of every fold.
// The simpler model wins unless the richer one's held-out RMS is better by more than
// `min_relative_gain` (a tie is parsimony's) AND the gain is more than noise: larger than twice
// the difference's standard error (from the per-frame differences of the squared error sums), or
// the rational model predicts more than n/2 + sqrt(n) of the n held-out frames better (a sign
// test at two standard deviations: a wide lens's edge frames make the standard error large
// exactly where the simpler model fails most).
//
// Each candidate is also fitted on all views (fit RMS, and the cameras, for comparisons such as
// the difference from a reference calibration); the caller's final fit uses `chosen`.
//
// Not possible (fewer than `min_frames` frames, a candidate's fit failing in a fold): the
// configured model is kept, `cross_validated` is false and `reason` says why; never throws for
// bad data.
#include <cmath>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/observation.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "models/camera_model.h"

namespace owlcal::fitting {

struct LensModelChoiceOptions {
  bool enabled = true;               // false: keep the configured model, no cross-validation
  int folds = 5;                     // k of k-fold (at most the number of frames)
  int min_frames = 6;                // fewer frames: no cross-validation (the configured model)
  double min_relative_gain = 0.002;  // the richer model must cut held-out RMS by more than this
  bool Check(std::string* why) const;
  static LensModelChoiceOptions Off() {
    LensModelChoiceOptions o;
    o.enabled = false;
    return o;
  }
};

// One candidate model's numbers.
struct LensModelScore {
  models::DistortionModel model = models::DistortionModel::kOpenCv5;
  std::string name;                       // "opencv5" or "opencv8"
  bool ok = false;                        // every fold and the full fit worked
  std::string message;                    // why not, naming the fold
  double fit_rms_px = 0;                  // all views, the fit's own RMS (joint for stereo)
  double heldout_rms_px = 0;              // pooled over all held-out corners
  double heldout_rms_eye_px[2] = {0, 0};  // per eye (stereo); [0] only for one camera
  std::vector<double> fold_rms_px;        // per fold
  int num_heldout_corners = 0;
  StereoFit full;                 // the fit on all views (stereo only)
  IntrinsicsFit full_intrinsics;  // the fit on all views (one camera only)
};

struct LensModelChoice {
  bool cross_validated = false;  // false: `chosen` is the configured model, `reason` why
  models::DistortionModel chosen = models::DistortionModel::kOpenCv5;
  std::string chosen_name = "opencv5";
  std::string reason;  // one sentence with the numbers
  int folds = 0;
  int num_frames = 0;
  std::vector<LensModelScore> scores;  // [opencv5, opencv8] when cross-validated
  double gain_px = 0;                  // heldout RMS opencv5 - opencv8
  double gain_se_px = 0;               // its standard error (delta method over frames)
  int frames_better = 0;               // held-out frames the rational model predicts better
  int frames_compared = 0;             // held-out frames both models placed
  double time_s = 0;

  const LensModelScore* Score(models::DistortionModel m) const;
};

// Stereo: left_views (eye 0) and right_views (eye 1) as for FitStereo; options.intrinsics.model
// is the model kept when the choice is off or not possible.
LensModelChoice ChooseStereoLensModel(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& choice);

// One camera (FitIntrinsics), views all of one eye.
LensModelChoice ChooseIntrinsicsLensModel(const std::vector<calib::View>& views,
                                          int width,
                                          int height,
                                          const IntrinsicsFitOptions& options,
                                          const LensModelChoiceOptions& choice);

std::string DistortionModelName(models::DistortionModel m);  // "opencv5" / "opencv8"

// The board's bow (fitting/board_warp.h) chosen the same way: flat and bowed
// (StereoFitOptions::fit_board_warp) are cross-validated over frames with the model in
// options.intrinsics.model, each held-out frame placed on the board bow its training folds
// fitted; the bow wins when its held-out RMS is smaller by more than choice.min_relative_gain
// AND the gain is more than noise, by the lens model's test (twice its standard error, or better
// on most held-out frames): a bow is a richer model too, and one that the held-out views do not
// ask for still moves the focal lengths by several sigma (kit2020: +9 px, 7 sigma, for a gain of
// 1.9 standard errors), so parsimony keeps the flat board.
// warp / warp_sigma: the bowed fit on all views, in the target's unit; explained_fraction:
// 1 - RMS_bowed^2 / RMS_flat^2 of the fits on all views (the share of the flat fit's squared
// residual the bow explains), heldout_explained_fraction the same of the held-out RMS.
struct BoardWarpChoice {
  bool cross_validated = false;
  bool bowed = false;  // chosen (the configured setting when not cross-validated)
  std::string reason;
  int folds = 0;
  int num_frames = 0;
  std::vector<LensModelScore> scores;  // [flat, bowed] when cross-validated (name "flat"/"bowed")
  double gain_px = NAN;                // held-out RMS flat - bowed
  double gain_se_px = NAN;
  int frames_better = 0;    // held-out frames the bowed board predicts better
  int frames_compared = 0;  // held-out frames both placed
  double warp[2] = {NAN, NAN};
  double warp_sigma[2] = {NAN, NAN};
  double explained_fraction = NAN;
  double heldout_explained_fraction = NAN;
  double time_s = 0;

  const LensModelScore* Chosen() const;  // null when not cross-validated
};

BoardWarpChoice ChooseStereoBoardWarp(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& choice);
nlohmann::json BoardWarpChoiceToJson(const BoardWarpChoice& c);
// results.json: diagnostics.board_warp_choice and inputs.board_warp.
void AppendBoardWarpChoiceToResult(const BoardWarpChoice& c, CalibrationResult* result);

// {cross_validated, chosen, reason, folds, num_frames, gain_px, gain_se_px, candidates: [{model,
// ok, message, fit_rms_px, heldout_rms_px, heldout_rms_left_px, heldout_rms_right_px,
// fold_rms_px, num_heldout_corners}]}
nlohmann::json LensModelChoiceToJson(const LensModelChoice& c);

// results.json: diagnostics.lens_model_choice (the JSON above) and inputs.lens_model
// ("auto: opencv8 chosen by 5-fold cross-validation" or why not).
void AppendLensModelChoiceToResult(const LensModelChoice& c, CalibrationResult* result);

}  // namespace owlcal::fitting
