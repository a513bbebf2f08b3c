#pragma once
// The table builders of MakeTables (reports/report.h), internal to reports/: each appends its
// tables to `out` only when the report data has what they show. The result's diagnostics in
// reports/report_diagnostic_tables.cc, the measurement runs in reports/report_run_tables.cc.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reports/report_data.h"
#include "reports/table.h"

namespace owlcal::reports::internal {

// A fraction as a percentage with `sig` significant digits; empty when not finite.
std::string Pct(double rel, int sig = 3);
// "yes" or "no".
std::string Bool(bool b);

// lens_model: the lens model choice by cross-validation (fitting/lens_model_choice.h).
void AppendLensModelTable(const ReportData& d, std::vector<Table>* out);
// latency_check, alignment_check, field_of_view: measured numbers against their references
// (evaluation/reference_checks.h).
void AppendReferenceCheckTables(const ReportData& d, std::vector<Table>* out);
// tag_coverage, tag_servo_ends: what the tag sheets add to the head fit.
void AppendTagTables(const ReportData& d, std::vector<Table>* out);
// board_warp: flat or bowed board by cross-validation.
void AppendBoardWarpTable(const ReportData& d, std::vector<Table>* out);
// reference_comparison: against a reference calibration of the same images.
void AppendReferenceComparisonTable(const ReportData& d, std::vector<Table>* out);

// ranging, ranging_summary: vergence ranging per fixation and its robust summary.
void AppendRangingTables(const ReportData& d, std::vector<Table>* out);
// step_metrics: the step-response metrics of every trial.
void AppendStepMetricsTable(const ReportData& d, std::vector<Table>* out);
// settling_model: the loop model against the measured trials.
void AppendSettlingTable(const ReportData& d, std::vector<Table>* out);
// saccade: the calibrated-map saccade against the physical bound and the P loop.
void AppendSaccadeTable(const ReportData& d, std::vector<Table>* out);
// gain_study: the incremental P loop's gain limits (model).
void AppendGainStudyTable(const ReportData& d, std::vector<Table>* out);
// person_work: the placements and the robot's time per protocol (reports/person_work_table.cc).
void AppendPersonWorkTable(const ReportData& d, std::vector<Table>* out);
// limits: servo limits, configured against measured.
void AppendLimitsTable(const ReportData& d, std::vector<Table>* out);

}  // namespace owlcal::reports::internal
