#pragma once
// K-fold cross-validation over frames (internal to fitting/): how the lens model and the board
// bow are chosen (fitting/lens_model_choice.h says why and how). The frames are dealt into folds,
// each fold is fitted on the others, and each held-out frame is placed by its own board pose with
// the trained cameras (and right_from_left) fixed; its pixel errors are pooled per frame.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "calib/observation.h"
#include "fitting/lens_model_choice.h"
#include "fitting/stereo_fit.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting::internal {

// Solver tolerance of the fold refits: a held-out RMS needs 4 digits, not the final fit's 12.
constexpr double kRefitTolerance = 1e-8;

// The sums of one held-out frame: squared pixel errors and corners, per eye.
struct FrameError {
  double sum_sq[2] = {0, 0};
  int n[2] = {0, 0};
};
// The trained model a fold's held-out frames are placed with.
struct Trained {
  bool ok = false;
  std::string message;
  models::CameraIntrinsics cams[2];
  models::Rigid3d right_from_left;
  double warp[2] = {0, 0};  // the board's bow, when the fit fitted it
};
// What a stereo fit on the training folds gives the held-out frames.
Trained TrainedOf(const StereoFit& f);

// A fold's fit: the training views of each eye -> the trained model.
using TrainFn = std::function<Trained(const std::vector<calib::View>* train_views)>;

// Runs the k-fold cross-validation of one model. views[e]: all views of eye e (views[1] empty
// for one camera). train(train_views) fits; returns the per-frame errors by frame.
void CrossValidate(const std::vector<calib::View>* views[2],
                   const std::vector<int>& frames,
                   int folds,
                   const TrainFn& train,
                   LensModelScore* score,
                   std::map<int, FrameError>* per_frame);

// Frames (sorted, unique) over both eyes' views.
std::vector<int> FramesOf(const std::vector<calib::View>* views[2]);

// The standard error of a held-out RMS difference between two candidates [px]: from the
// per-frame differences of the squared error sums (delta method).
double GainStandardError(const std::map<int, FrameError> per_frame[2], double rms0, double rms1);

// Held-out frames both candidates placed (*compared), and of them those where the second
// predicts better (*better: smaller sum of squared errors over both eyes).
void CountFramesBetter(const std::map<int, FrameError> per_frame[2], int* better, int* compared);

// The richer candidate's held-out gain is more than noise: larger than twice its standard error,
// or better on more than n/2 + sqrt(n) of the n frames compared (a sign test at two standard
// deviations). An unknown standard error (one frame) counts as significant.
bool HeldOutGainSignificant(double gain_px, double gain_se_px, int better, int compared);

}  // namespace owlcal::fitting::internal
