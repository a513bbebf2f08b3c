#pragma once
// The report folder of a calibration run, from ReportData (reports/report_data.h):
//   OUT/figures/<name>.{png,svg,csv,gp}   reports/figures.h
//   OUT/tables/<name>.{csv,md,tex}        MakeTables below
//   OUT/report/index.html                 every figure and table, the settings and versions
//                                         that produced them, the step-metric definitions, the
//                                         ground-truth comparison (virtual Owl) and the list
//                                         of parameters the data could not determine.
#include <string>
#include <vector>

#include "reports/report_data.h"
#include "reports/table.h"

namespace owlcal::reports {

// parameters, solver, undetermined, truth_comparison (with truth), ranging, ranging_summary,
// step_metrics, gain_study, limits -- each only when it has data.
std::vector<Table> MakeTables(const ReportData& d);

// The part of a step not done at the end of a trial: 1 - mean(y) over the last 10 % of the
// samples (at least 3), as a fraction of the step (0.05 = 5 % short); NaN with < 3 samples.
double SteadyStateError(const StepTrace& s);

struct ReportOptions {
  bool draw = true;  // run gnuplot (false: write .csv/.gp only)
  std::string title = "owlcal calibration report";
};

struct ReportOutput {
  std::string index_html;            // path
  std::vector<std::string> figures;  // names drawn or written
  std::vector<std::string> tables;
  std::vector<std::string> warnings;  // gnuplot missing or failing, ...
};

ReportOutput WriteReport(const ReportData& d, const std::string& out_dir, const ReportOptions& options = {});

}  // namespace owlcal::reports
