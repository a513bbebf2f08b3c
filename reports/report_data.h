#pragma once
// Everything the report is drawn from, besides results.json: the evaluations (fitting/
// ranging_eval.h, limits_eval.h, step_response.h, ploop_analysis.h), the points behind the
// residual and coverage figures, the robot configuration, the virtual Owl's truth and the
// settings of the run. Written as DIR/evaluation.json so `owlcal report DIR` can regenerate
// every figure and table without the robot or the dataset.
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "fitting/limits_eval.h"
#include "fitting/ploop_analysis.h"
#include "fitting/ranging_eval.h"
#include "fitting/result.h"
#include "fitting/step_response.h"
#include "models/head_model.h"
#include "models/robot_config.h"

namespace owlcal::reports {

// One measured (or simulated) step response: y is the fraction of the step done (0 at rest,
// 1 on target), computed from the target's image offset.
struct StepTrace {
  double gain = 0;
  double amplitude_deg = 0;
  int trial = 0;
  std::string eye_axis;            // "right pan"
  std::vector<double> t_s;         // from the step command
  std::vector<double> y;
  double residual_px = 0;          // |target offset| after settling
  fitting::StepInfo info;          // of (t_s, y) with y_init 0, y_final 1
  bool simulated = false;
};

struct GainStudy {
  int delay_frames = 3;
  double fps = 30;
  std::vector<fitting::GainSettling> simulated;  // the delayed P-loop over a gain grid
  double critical_gain = 0, monotone_gain = 0;
  std::optional<fitting::GainSettling> fastest;
  // Physical lower bound per amplitude: slew at 400 deg/s + 100 ms (fast) and 300 deg/s +
  // 150 ms (slow) + one frame.
  std::vector<double> amplitudes_deg, lower_bound_fast_s, lower_bound_slow_s;
};

struct ResidualPoint {
  int eye = 0;
  int frame = 0;
  double x = 0, y = 0;    // measured corner [px]
  double dx = 0, dy = 0;  // reprojected - measured [px]
};

struct CoveragePoint {
  int eye = 0;
  double x = 0, y = 0;
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

struct ReportData {
  fitting::CalibrationResult result;
  models::RobotConfig config = models::DefaultRobotConfig();
  std::optional<models::HeadModel> truth;       // virtual Owl only, in the fit's gauge
  std::optional<fitting::RangingEvaluation> ranging;
  std::optional<fitting::LimitsEvaluation> limits;
  std::vector<StepTrace> steps;
  std::optional<GainStudy> gains;
  std::vector<ResidualPoint> residuals;
  std::vector<CoveragePoint> coverage;
  std::vector<ViewStat> views;                  // reports/fit_points.h
  std::vector<BoardOutline> boards;
  nlohmann::json settings = nlohmann::json::object();  // command line, seed, robot, protocols, timings
};

// The gain study of the delayed P-loop for d frames (gain grid 0.005 .. 0.6, step 0.005).
GainStudy MakeGainStudy(int delay_frames, double fps = 30.0);

// evaluation.json (everything but `result`, which is results.json).
nlohmann::json EvaluationToJson(const ReportData& data);
// Fills everything but `result`; throws naming the field on a malformed document.
void EvaluationFromJson(const nlohmann::json& j, ReportData* data);

nlohmann::json RobotConfigToJson(const models::RobotConfig& c);
models::RobotConfig RobotConfigFromJson(const nlohmann::json& j);

// Reads DIR/results.json and DIR/evaluation.json (the latter optional).
ReportData ReadReportData(const std::string& dir);
// Writes DIR/results.json and DIR/evaluation.json.
void WriteReportData(const ReportData& data, const std::string& dir);

}  // namespace owlcal::reports
