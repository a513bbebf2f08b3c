// MakeTables: the report's tables in their order, from the fit's parameters and solves (here),
// the result's diagnostics (reports/report_diagnostic_tables.cc) and the measurement runs
// (reports/report_run_tables.cc); and SteadyStateError.
#include "reports/report.h"

#include <algorithm>
#include <cmath>

#include "evaluation/servo_map_eval.h"
#include "evaluation/truth_compare.h"

#include "reports/report_tables.h"

namespace owlcal::reports {
namespace internal {

std::string Pct(double rel, int sig) { return std::isfinite(rel) ? Fmt(100 * rel, sig) : ""; }
std::string Bool(bool b) { return b ? "yes" : "no"; }

}  // namespace internal
namespace {

using internal::Bool;
using internal::Pct;

// Whether any parameter has a true value (the virtual Owl's).
bool AnyTruth(const ReportData& d) {
  for (const auto& p : d.result.parameters)
    if (p.truth) return true;
  return false;
}

// parameters: every fitted parameter with its sigma (and the truth, when known).
void AppendParameterTable(const ReportData& d, bool any_truth, std::vector<Table>* out) {
  Table t{"parameters",
          "Fitted parameters with their standard deviation (1\u03c3)",
          {"name", "value", "\u03c3", "unit", "determined"},
          {}};
  if (any_truth) {
    t.header.push_back("truth");
    t.header.push_back("error");
    t.header.push_back("error / \u03c3");
  }
  for (const auto& p : d.result.parameters) {
    std::vector<std::string> r = {p.name,
                                  FmtWithSigma(p.value, p.sigma),
                                  p.determined ? Fmt(p.sigma, 2) : "",
                                  DisplayUnit(p.unit),
                                  p.held ? "held: " + p.note : (p.determined ? "yes" : "no: " + p.note)};
    if (any_truth) {
      if (p.truth) {
        r.push_back(Fmt(*p.truth, 6));
        r.push_back(Fmt(p.value - *p.truth, 3));
        r.push_back(p.determined && p.sigma > 0 ? Fmt((p.value - *p.truth) / p.sigma, 2) : "");
      } else {
        r.insert(r.end(), {"", "", ""});
      }
    }
    t.rows.push_back(r);
  }
  out->push_back(t);
}

// solver: the solver summaries.
void AppendSolverTable(const ReportData& d, std::vector<Table>* out) {
  if (d.result.summaries.empty()) return;
  Table t{"solver",
          "Solver summaries",
          {"problem", "termination", "iterations", "RMS [px]", "residuals", "outliers", "time [s]", "usable"},
          {}};
  for (const auto& s : d.result.summaries)
    t.rows.push_back({s.problem,
                      s.termination,
                      std::to_string(s.iterations),
                      Fmt(s.rms_px, 4),
                      std::to_string(s.num_residuals),
                      std::to_string(s.num_outliers),
                      Fmt(s.time_s, 3),
                      Bool(s.usable)});
  out->push_back(t);
}

// undetermined: the parameters the data could not determine, and the warnings.
void AppendUndeterminedTable(const ReportData& d, std::vector<Table>* out) {
  Table t{
      "undetermined", "Parameters the data could not determine, and warnings", {"parameter or warning", "reason"}, {}};
  for (const auto& p : d.result.parameters)
    if (!p.determined && !p.held) t.rows.push_back({p.name, p.note});
  for (const auto& w : d.result.warnings) t.rows.push_back({"warning", w});
  for (const auto& n : d.result.notes) t.rows.push_back({"note", n});
  out->push_back(t);
}

// truth_comparison: fitted against true values (virtual Owl).
void AppendTruthComparisonTable(const ReportData& d, bool any_truth, std::vector<Table>* out) {
  if (!any_truth) return;
  const evaluation::TruthComparison c = evaluation::CompareWithTruth(d.result);
  Table t{"truth_comparison",
          "Virtual Owl: fitted vs true values (" + std::to_string(c.num_with_sigma) + " with \u03c3, " +
              Pct(c.fraction_within_2sigma, 3) + " % within \u00b12\u03c3, RMS z = " + Fmt(c.rms_z, 3) + ")",
          {"name", "value", "truth", "error", "unit", "\u03c3", "error / \u03c3", "within \u00b12\u03c3"},
          {}};
  for (const auto& r : c.rows)
    t.rows.push_back({r.name,
                      Fmt(r.value, 7),
                      Fmt(r.truth, 7),
                      Fmt(r.error, 3),
                      DisplayUnit(r.unit),
                      Fmt(r.sigma, 2),
                      Fmt(r.z, 3),
                      std::isfinite(r.z) ? Bool(r.within_2sigma) : "n/a"});
  out->push_back(t);
}

void AppendServoMapTruthTable(const ReportData& d, std::vector<Table>* out) {
  if (!d.truth || !d.result.head) return;
  // Whole maps, not just their parameters: fitted minus true angle over the range the run used.
  Table t{"servo_map_truth",
          "Virtual Owl: fitted servo maps vs the truth over the range the run used (the measured stops minus "
          "the margin after the limits protocol, else the robot file's)",
          {"servo", "range [\u00b5s]", "RMS [deg]", "max |error| [deg]", "mean error [deg]"},
          {}};
  for (int s = 0; s < models::kNumServos; ++s) {
    const fitting::Parameter* p = d.result.Find("servo." + std::string(models::kServoNames[s]) + ".deg_per_us");
    if (!p || !p->determined) continue;
    const models::ServoConfig& c = d.config.servos[s];
    const evaluation::ServoMapError e =
        evaluation::ServoMapErrorOverRange(*d.result.head, *d.truth, s, c.min_us, c.max_us);
    t.rows.push_back({models::kServoNames[s],
                      std::to_string(c.min_us) + "\u2013" + std::to_string(c.max_us),
                      Fmt(e.rms_deg, 3),
                      Fmt(e.max_abs_deg, 3),
                      Fmt(e.mean_deg, 3)});
  }
  if (!t.rows.empty()) out->push_back(t);
}

}  // namespace

double SteadyStateError(const StepTrace& s) {
  // 1 - the mean of the last 10 % of the trace (at least 3 samples): the part of the step not
  // done when the trial ended, whether or not it settled.
  if (s.y.size() < 3) return NAN;
  const size_t n = std::max<size_t>(3, s.y.size() / 10);
  double sum = 0;
  for (size_t k = s.y.size() - n; k < s.y.size(); ++k) sum += s.y[k];
  return 1.0 - sum / n;
}

std::vector<Table> MakeTables(const ReportData& d) {
  std::vector<Table> out;
  const bool any_truth = AnyTruth(d);
  AppendParameterTable(d, any_truth, &out);
  internal::AppendLensModelTable(d, &out);
  internal::AppendReferenceCheckTables(d, &out);
  internal::AppendTagTables(d, &out);
  internal::AppendBoardWarpTable(d, &out);
  internal::AppendReferenceComparisonTable(d, &out);
  AppendSolverTable(d, &out);
  AppendUndeterminedTable(d, &out);
  AppendTruthComparisonTable(d, any_truth, &out);
  AppendServoMapTruthTable(d, &out);
  internal::AppendRangingTables(d, &out);
  internal::AppendStepMetricsTable(d, &out);
  internal::AppendSettlingTable(d, &out);
  internal::AppendSaccadeTable(d, &out);
  internal::AppendGainStudyTable(d, &out);
  internal::AppendLimitsTable(d, &out);
  internal::AppendPersonWorkTable(d, &out);
  return out;
}

}  // namespace owlcal::reports
