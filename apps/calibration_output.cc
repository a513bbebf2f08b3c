#include "apps/calibration_output.h"

#include <CLI/CLI.hpp>

#include <iostream>

#include "apps/output_folder.h"
#include "evaluation/truth_compare.h"
#include "owlcal_git.h"
#include "owlcal_version.h"
#include "pipeline/bring_up.h"
#include "reports/exports.h"
#include "reports/report.h"
#include "reports/report_data.h"
#include "reports/table.h"
#include "robot/robot_file.h"

namespace owlcal::apps {

void Progress::operator()(const std::string& msg) const {
  if (quiet_) return;
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
  std::cout << "[" << name_ << " " << std::fixed;
  std::cout.precision(1);
  std::cout << s << " s] " << msg << std::endl;
  std::cout.unsetf(std::ios::fixed);
}

void PrintWarning(const std::string& message) { std::cerr << "warning: " << message << std::endl; }

nlohmann::json SoftwareInputs() {
  return {{"name", "owlcal"}, {"version", OWLCAL_VERSION}, {"git", OWLCAL_GIT_DESCRIBE}};
}

void StampRun(const std::string& run_id, fitting::CalibrationResult* result) {
  result->software_version = OWLCAL_VERSION;
  result->run_id = run_id;
  result->inputs["software"] = SoftwareInputs();
}

void WriteCalibrationFolder(evaluation::CalibrationRun* run,
                            const std::string& run_id,
                            const std::string& out,
                            bool draw,
                            const Progress& progress) {
  StampRun(run_id, &run->result);
  reports::WriteReportData(*run, out);
  // The robot file the run suggests (pipeline/bring_up.h CorrectedRobotFile): what the bring-up
  // learned and the fitted centres, scales and IPD, for the user to compare with theirs.
  if (run->result.head || run->result.diagnostics.contains("bring_up")) {
    const nlohmann::json b = run->result.diagnostics.value("bring_up", nlohmann::json::object());
    models::RobotConfig file = run->config;
    if (b.contains("servos"))
      for (int s = 0; s < models::kNumServos; ++s) {
        const nlohmann::json& f = b["servos"][s]["file"];
        file.servos[s].min_us = f.value("min_us", file.servos[s].min_us);
        file.servos[s].max_us = f.value("max_us", file.servos[s].max_us);
        file.servos[s].centre_us = f.value("centre_us", file.servos[s].centre_us);
        file.servos[s].direction = f.value("direction", file.servos[s].direction);
      }
    std::vector<std::string> changes;
    const models::RobotConfig corrected = pipeline::CorrectedRobotFile(file, run->config, run->result, &changes);
    robot::SaveRobotFile(corrected, out + "/robot_corrected.yaml");
    progress("robot file as measured: " + out + "/robot_corrected.yaml (" + std::to_string(changes.size()) +
             " fields differ from yours)");
  }
  const reports::ExportSet ex = reports::WriteCalibrationFiles(*run, out);
  for (const auto& s : ex.skipped) progress("export skipped: " + s);
  reports::ReportOptions ro;
  ro.draw = draw;
  const reports::ReportOutput rep = reports::WriteReport(*run, out, ro);
  for (const auto& w : rep.warnings) progress("report: " + w);
  if (run->truth) {
    const evaluation::TruthComparison c = evaluation::CompareWithTruth(run->result);
    progress("truth: " + std::to_string(c.num_with_sigma) + " parameters with sigma, " +
             reports::Fmt(100 * c.fraction_within_2sigma, 3) + " % within 2 sigma, worst " + c.worst +
             " (z = " + reports::Fmt(c.worst_z, 3) + ")");
  }
  progress("done: " + rep.index_html);
}

void AddCalibrationOutputOptions(CLI::App* cmd, bool* no_figures, bool* quiet, std::string* lens_model) {
  cmd->add_flag("--no-figures", *no_figures, "write figure data and scripts without running gnuplot");
  cmd->add_flag("--quiet", *quiet, "no progress output");
  cmd->add_option("--lens-model",
                  *lens_model,
                  "lens model of both eyes: auto (opencv5 or the rational opencv8, chosen by 5-fold cross-validation "
                  "over the chessboard views: the smaller held-out RMS), opencv5 or opencv8")
      ->capture_default_str();
}

}  // namespace owlcal::apps
