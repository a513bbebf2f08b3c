#include "apps/calibration_output.h"

#include <CLI/CLI.hpp>

#include <iostream>

#include "fitting/truth_compare.h"
#include "owlcal_git.h"
#include "owlcal_version.h"
#include "reports/exports.h"
#include "reports/report.h"
#include "reports/report_data.h"
#include "reports/table.h"

namespace owlcal::apps {

void Progress::operator()(const std::string& msg) const {
  if (quiet_) return;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  std::cout << "[" << name_ << " " << std::fixed;
  std::cout.precision(1);
  std::cout << s << " s] " << msg << std::endl;
  std::cout.unsetf(std::ios::fixed);
}

fitting::LatencyTruth LatencyTruthOf(const sim::RobotTruth& truth) {
  fitting::LatencyTruth t;
  t.fps = truth.stream.fps;
  t.latency_ms = truth.stream.latency_ms;
  t.eye_offset_ms = truth.stream.eye_offset_ms;
  t.rolling_shutter_ms = truth.stream.rolling_shutter_ms;
  t.drop_probability = truth.stream.drop_probability;
  for (int s = 0; s < models::kNumServos; ++s) {
    t.slew_deg_per_s[s] = truth.servos[s].slew_deg_per_s;
    t.lag_s[s] = truth.servos[s].lag_s;
  }
  t.head = truth.HeadModel();
  return t;
}

nlohmann::json SoftwareInputs() { return {{"name", "owlcal"}, {"version", OWLCAL_VERSION}, {"git", OWLCAL_GIT_DESCRIBE}}; }

void WriteCalibrationFolder(fitting::CalibrationRun* run, const std::string& out, bool draw, const Progress& progress) {
  run->result.software_version = OWLCAL_VERSION;
  run->result.inputs["software"] = SoftwareInputs();
  reports::WriteReportData(*run, out);
  const reports::ExportSet ex = reports::WriteCalibrationFiles(*run, out);
  for (const auto& s : ex.skipped) progress("export skipped: " + s);
  reports::ReportOptions ro;
  ro.draw = draw;
  const reports::ReportOutput rep = reports::WriteReport(*run, out, ro);
  for (const auto& w : rep.warnings) progress("report: " + w);
  if (run->truth) {
    const fitting::TruthComparison c = fitting::CompareWithTruth(run->result);
    progress("truth: " + std::to_string(c.num_with_sigma) + " parameters with sigma, " +
             reports::Fmt(100 * c.fraction_within_2sigma, 3) + " % within 2 sigma, worst " + c.worst + " (z = " +
             reports::Fmt(c.worst_z, 3) + ")");
  }
  progress("done: " + rep.index_html);
}

void AddCalibrationOutputOptions(CLI::App* cmd, bool* no_figures, bool* quiet, std::string* lens_model) {
  cmd->add_flag("--no-figures", *no_figures, "write figure data and scripts without running gnuplot");
  cmd->add_flag("--quiet", *quiet, "no progress output");
  cmd->add_option("--lens-model", *lens_model,
                  "lens model of both eyes: auto (opencv5 or the rational opencv8, chosen by 5-fold cross-validation "
                  "over the chessboard views: the smaller held-out RMS), opencv5 or opencv8")
      ->capture_default_str();
}

}  // namespace owlcal::apps
