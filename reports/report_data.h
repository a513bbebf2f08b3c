#pragma once
// The files of a calibration run (evaluation/calibration_run.h): DIR/results.json (the fitted
// result) and DIR/evaluation.json (everything else the report is drawn from), so `owlcal
// report DIR` can regenerate every figure and table without the robot or the dataset.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/calibration_run.h"
#include "fitting/robot_config_json.h"
#include "models/robot_config.h"

namespace owlcal::reports {

// The report is drawn from a calibration run (evaluation/calibration_run.h); these names are
// kept for the report code.
using ReportData = evaluation::CalibrationRun;
using StepTrace = fitting::StepTrace;
using GainStudy = fitting::GainStudy;
using ResidualPoint = evaluation::ResidualPoint;
using CoveragePoint = evaluation::CoveragePoint;
using ViewStat = evaluation::ViewStat;
using BoardOutline = evaluation::BoardOutline;

// evaluation.json (everything but `result`, which is results.json; its `run_id` is the result's).
nlohmann::json EvaluationToJson(const ReportData& data);
// Fills everything but `result`; throws naming the field on a malformed document.
void EvaluationFromJson(const nlohmann::json& j, ReportData* data);

using fitting::RobotConfigFromJson;
using fitting::RobotConfigToJson;

// Reads DIR/results.json and DIR/evaluation.json (the latter optional); throws when the files of
// DIR are of different runs (fitting/calibration_folder.h CheckOneRun).
ReportData ReadReportData(const std::string& dir);
// Writes DIR/results.json and DIR/evaluation.json.
void WriteReportData(const ReportData& data, const std::string& dir);

}  // namespace owlcal::reports
