#pragma once
// The result of a fit, as written to results.json. Every number is {name, value, sigma, unit} and,
// on the virtual Owl, its truth. Parameters the data could not determine carry determined = false
// and a reason instead of a silent number.
//
// Names: left.fx, left.fy, left.cx, left.cy, left.k1 ... ; right.*; stereo.baseline_mm,
// stereo.rx_deg ...; servo.Rx.centre_us, servo.Rx.deg_per_us, servo.Rx.quad_deg,
// servo.Rx.cubic_deg, servo.Rx.hysteresis_us; head.ipd_mm; ...
//
// The typed parts (cameras, stereo, head) hold the full-precision estimates that reports and
// exports use; `parameters` is the flat list a student reads.
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "models/camera_model.h"
#include "models/head_model.h"
#include "models/rigid3.h"

namespace owlcal::fitting {

struct Parameter {
  std::string name;
  double value = 0;
  double sigma = 0;  // 1-sigma from the fit covariance; NaN when not determined
  std::string unit;
  std::optional<double> truth;  // virtual Owl only
  bool determined = true;
  std::string note;  // why not determined, or how it was fixed
  // Held at its value by an option (--fix k3, OpenCV's CALIB_FIX_*): sigma 0, determined false.
  bool held = false;
};

struct SolveSummary {
  std::string problem;      // "intrinsics.left", "stereo", "head" ...
  std::string termination;  // Ceres termination type
  std::string message;
  double initial_cost = 0, final_cost = 0;
  int iterations = 0;
  double time_s = 0;
  double rms_px = 0;  // reprojection RMS over the inliers
  int num_residuals = 0;
  int num_outliers = 0;  // observations rejected (listed in the problem's diagnostics)
  bool usable = false;
};

struct StereoEstimate {
  models::Rigid3d right_from_left;  // x_in_right = right_from_left * x_in_left (OpenCV's R, T)
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  // [rot vec (rad), t (m)]
  // The joint covariance of the stereo fit with its correlations (focal length and baseline
  // are strongly correlated, which per-parameter sigmas lose): `full_names` in order, left
  // intrinsics, right intrinsics, rotation vector [rad], T [m]; units of each name. Empty when
  // the fit's length unit was not metres.
  std::vector<std::string> full_names;
  Eigen::MatrixXd full_covariance;
};

struct CalibrationResult {
  std::string software_version;
  // The run that wrote this result ("" when unknown: an older file or a result never written).
  // Every file of a calibration folder carries it, so a reader can tell a folder holding one
  // run from one mixing runs (fitting/calibration_folder.h).
  std::string run_id;
  std::vector<Parameter> parameters;
  std::vector<SolveSummary> summaries;
  std::vector<std::string> warnings;  // e.g. "k3 not determined: all views fronto-parallel"
  // What a fit dropped or worked around that asks nothing of the user (e.g. the views with too few
  // corners, grouped): counted and listed in the report's appendix, never in the verdict.
  std::vector<std::string> notes;
  std::optional<models::CameraIntrinsics> cameras[2];
  std::optional<StereoEstimate> stereo;
  std::optional<models::HeadModel> head;
  nlohmann::json inputs = nlohmann::json::object();       // observation file + its FNV-1a 64 hash, options
  nlohmann::json diagnostics = nlohmann::json::object();  // per-view RMS, outliers, coverage ...
  // {status: good|poor|unusable, reasons: [...], advice: [...], metrics: {...}} of the set the
  // result came from (evaluation/set_verdict.h); null when no verdict was made.
  nlohmann::json verdict;

  const Parameter* Find(const std::string& name) const;
  Parameter& Set(const Parameter& p);  // adds or replaces by name
};

nlohmann::json ToJson(const CalibrationResult& r);
CalibrationResult ResultFromJson(const nlohmann::json& j);
// File I/O; errors name the path (and the field for a malformed file).
void WriteResultJson(const CalibrationResult& r, const std::string& path);
CalibrationResult ReadResultJson(const std::string& path);

}  // namespace owlcal::fitting
