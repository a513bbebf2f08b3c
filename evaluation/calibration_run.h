#pragma once
// Everything a calibration run computes from its datasets: the fitted result (results.json)
// and the evaluations and points the report is drawn from (evaluation.json): ranging, limits,
// step responses, the gain study, the reprojection residuals, image coverage, per-view RMS and
// board outlines of the intrinsics fits (evaluation/fit_points.h), the robot configuration, the
// virtual Owl's truth and the settings of the run. reports/ turns it into files
// (reports/report_data.h names it ReportData).
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "evaluation/limits_eval.h"
#include "evaluation/ranging_eval.h"
#include "evaluation/saccade_eval.h"
#include "fitting/ploop_analysis.h"
#include "fitting/result.h"
#include "fitting/servo_resolution_fit.h"
#include "fitting/settling_model.h"
#include "fitting/step_response.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::evaluation {

// One corner of an intrinsics fit: where it was detected and its reprojection error.
struct ResidualPoint {
  int eye = 0;
  int frame = 0;
  double x = 0, y = 0;    // measured corner [px]
  double dx = 0, dy = 0;  // reprojected - measured [px]
};

// One detected corner in the image (coverage of the intrinsics views).
struct CoveragePoint {
  int eye = 0;
  double x = 0, y = 0;  // [px]
};

// One calibration view of one eye: its RMS reprojection error and a name a student can find
// the image by ("intrinsics frame 12", "pair left07.png").
struct ViewStat {
  int eye = 0;
  int frame = 0;
  std::string name;
  double rms_px = 0;
  int num_corners = 0;
  int num_over_1px = 0;  // corners with |residual| > 1 px
};

// A board pose seen by one eye: the outline of the target's corner grid in that camera's frame
// [m, or the target's unit], corners in order (for the 3D pose view).
struct BoardOutline {
  int eye = 0;
  int frame = 0;
  std::array<Eigen::Vector3d, 4> corners_in_cam;
};

struct CalibrationRun {
  fitting::CalibrationResult result;
  models::RobotConfig config = models::DefaultRobotConfig();
  std::optional<models::HeadModel> truth;  // virtual Owl only, in the fit's gauge
  std::optional<RangingEvaluation> ranging;
  std::optional<LimitsEvaluation> limits;
  std::vector<fitting::StepTrace> steps;  // every step trial (P loop and saccade), failed ones too
  std::optional<fitting::GainStudy> gains;
  std::vector<fitting::ServoResolutionResult> resolution;  // PWM step and dead band per servo, measured
  std::optional<fitting::SettlingStudy> settling;          // loop model vs measured settling
  std::optional<SaccadeEvaluation> saccade;                // calibrated saccade vs bound and P loop
  std::vector<ResidualPoint> residuals;
  std::vector<CoveragePoint> coverage;
  std::vector<ViewStat> views;  // evaluation/fit_points.h
  std::vector<BoardOutline> boards;
  nlohmann::json settings = nlohmann::json::object();  // command line, seed, robot, protocols, timings
};

}  // namespace owlcal::evaluation
