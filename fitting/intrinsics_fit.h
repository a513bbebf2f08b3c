#pragma once
// Per-camera intrinsics: pinhole + OpenCV 5- or 8-coefficient distortion (models/camera_model.h)
// from views of a planar target (calib::View, all of one eye).
//
// Steps: (1) initialisation that needs no guess: cv::initCameraMatrix2D (Zhang's closed form
// from the views' homographies, principal point at the image centre) + cv::solvePnP per view;
// (2) Ceres, autodiff through models::OpenCvCamera<N>, board poses cam_from_target as 7-blocks
// [qx qy qz qw tx ty tz] on ProductManifold(EigenQuaternionManifold, EuclideanManifold<3>),
// residuals whitened by the corner sigma; optional robust loss; (3) outlier rejection at
// outlier_threshold_sigma and a re-solve; (4) observability and covariance of the intrinsic
// parameters by the one rule of fitting/observability.h (board poses eliminated), scaled by the
// corner noise measured from the residuals when corner_sigma_px == 0; parameters that are fixed,
// not determined by that rule, or with a sigma too large to mean anything are listed in
// `undetermined` with the reason, and never reported as determined; (5) outputs.
//
// Degenerate input (fewer than 3 distinct board orientations, views with fewer than
// min_corners_per_view corners, no views) returns ok = false with a message naming what cannot
// be determined; it never throws for bad data.
//
// Units: pixels for fx fy cx cy, dimensionless distortion; poses in the target's length unit
// (metres for real boards).
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/observation.h"
#include "fitting/observability.h"
#include "fitting/result.h"
#include "models/camera_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting {

enum class RobustLoss { kNone, kHuber, kCauchy };

struct IntrinsicsFitOptions;
// `options` with `model`, and for opencv8 its rational_fix_radial added to fix_radial.
IntrinsicsFitOptions WithModel(IntrinsicsFitOptions options, models::DistortionModel model);

struct IntrinsicsFitOptions {
  models::DistortionModel model = models::DistortionModel::kOpenCv5;
  bool fix_aspect_ratio = false;     // fy = fx (CALIB_FIX_ASPECT_RATIO with ratio 1)
  bool fix_principal_point = false;  // cx, cy stay at the image centre
  bool fix_k3 = false;               // k3 = 0 (CALIB_FIX_K3)
  // Radial coefficients held at 0 by number, 1..6 (CALIB_FIX_K1 ... CALIB_FIX_K6); a number the
  // model does not have (k4..k6 of opencv5) holds nothing.
  std::vector<int> fix_radial;
  // Radial coefficients held at 0 when the model is opencv8 only (the rational model's numerator
  // and denominator terms trade against each other: {2, 3, 5, 6} leaves (1 + k1 r^2) / (1 +
  // k4 r^2)); empty: all six fitted, as OpenCV's CALIB_RATIONAL_MODEL.
  std::vector<int> rational_fix_radial;
  bool fix_tangential = false;  // p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST)
  double corner_sigma_px = 0;   // corner noise; 0 = estimate from the residuals
  RobustLoss loss = RobustLoss::kNone;
  double loss_scale_sigma = 3.0;         // robust loss scale in units of corner sigma
  double outlier_threshold_sigma = 6.0;  // reject |residual| > this * sigma, refit; 0 = off
  int min_corners_per_view = 8;          // smaller views are dropped (and named)
  int max_iterations = 200;
  // A parameter is "undetermined" when sigma exceeds these: pixels params, distortion coeffs.
  double max_sigma_px = 50.0;
  double max_sigma_distortion = 5.0;
  // Null-space threshold of the observability rule (fitting/observability.h, rule 4).
  double rank_tolerance = kDefaultRankTolerance;
  // false: no observability analysis and no covariance (every sigma NaN, every free parameter
  // listed as undetermined "covariance not computed"); for the many refits of a cross-validation
  // (fitting/lens_model_choice.h), which only need the estimates.
  bool compute_covariance = true;
  // Ceres function, parameter and gradient tolerance of the solves (the refits of a
  // cross-validation need less than the final fit).
  double solver_tolerance = 1e-12;

  bool Check(std::string* why) const;
};

// One rejected corner observation.
struct RejectedObservation {
  int frame_index = 0;
  int eye = 0;
  int corner_id = 0;
  double residual_px = 0;  // |reprojection error| when rejected
};

struct IntrinsicsFit {
  bool ok = false;  // false: nothing here is usable; message says why
  std::string message;
  models::CameraIntrinsics camera;
  std::vector<int> frame_indices;                // per used view
  std::vector<models::Rigid3d> cam_from_target;  // per used view
  std::vector<double> view_rms_px;               // per used view, RMS of |error| per corner
  double rms_px = 0;                             // sqrt(sum |e|^2 / num corners) (OpenCV's RMS)
  double corner_sigma_px = 0;                    // used to whiten (given or estimated per axis)
  // Covariance of camera.params (fx fy cx cy dist...), physical units; rows/cols of fixed or
  // undetermined parameters are zero. param_names: "fx" "fy" "cx" "cy" "k1" "k2" "p1" "p2" "k3" ...
  Eigen::MatrixXd covariance;
  std::vector<std::string> param_names;
  std::vector<double> sigmas;  // sqrt(diag); NaN when undetermined
  std::vector<bool> determined;
  SolveSummary summary;
  std::vector<RejectedObservation> rejected;
  std::vector<std::string> dropped_views;  // "frame 3: 5 corners < 8"
  std::vector<std::string> undetermined;   // "k3: fixed by option fix_k3", "fx: ..." ...
};

IntrinsicsFit FitIntrinsics(const std::vector<calib::View>& views,
                            int width,
                            int height,
                            const IntrinsicsFitOptions& options);

// Names of the parameters of a model: fx fy cx cy k1 k2 p1 p2 k3 [k4 k5 k6].
std::vector<std::string> IntrinsicParamNames(models::DistortionModel model);
// Unit of a named intrinsic parameter: "px" or "" (dimensionless).
std::string IntrinsicParamUnit(const std::string& name);

// Adds <eye>.fx ... <eye>.k3 (value, sigma, unit, determined/note), the camera, the summary
// and per-view diagnostics to a result. eye_name: "left" or "right".
void AppendIntrinsicsToResult(const IntrinsicsFit& fit, const std::string& eye_name, CalibrationResult* result);

namespace internal {
// Indices into camera.params held fixed by the options (fy when the aspect ratio is tied).
std::vector<int> FixedIntrinsicIndices(const IntrinsicsFitOptions& options);
// Why a parameter with this sigma means nothing (empty when it is fine).
std::string SigmaTooLarge(const std::string& name, double sigma, const IntrinsicsFitOptions& options);
// Why a fixed parameter is fixed ("fixed at 0 by option fix_k3"); every such reason says
// "by option" (IsHeldReason).
std::string FixedReason(const std::string& name, const IntrinsicsFitOptions& options);
// True for a FixedReason text: the parameter was held by an option, not left undetermined by the data.
bool IsHeldReason(const std::string& why);
// Ceres summary -> SolveSummary (termination, message, costs, iterations, time).
SolveSummary ToSolveSummary(const std::string& problem, const void* ceres_summary);
}  // namespace internal

}  // namespace owlcal::fitting
