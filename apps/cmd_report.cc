// owlcal report DIR: regenerates the figures, tables, exports and report/index.html of a
// calibration folder from its results.json and evaluation.json (no robot, no dataset).
#include <filesystem>
#include <iostream>

#include "apps/command_registry.h"
#include "reports/exports.h"
#include "reports/report.h"
#include "reports/report_data.h"

namespace owlcal::apps {
namespace {

struct ReportCmdOptions {
  std::string dir;
  bool no_figures = false;
  bool no_exports = false;
};

int RunReport(const ReportCmdOptions& o) {
  if (!std::filesystem::exists(o.dir + "/results.json"))
    throw UsageError(o.dir + " has no results.json (run `owlcal calibrate --out " + o.dir + "` first)");
  const reports::ReportData d = reports::ReadReportData(o.dir);
  if (!o.no_exports) {
    const reports::ExportSet ex = reports::WriteCalibrationFiles(d, o.dir);
    for (const auto& s : ex.skipped) std::cout << "export skipped: " << s << "\n";
  }
  reports::ReportOptions ro;
  ro.draw = !o.no_figures;
  const reports::ReportOutput out = reports::WriteReport(d, o.dir, ro);
  for (const auto& w : out.warnings) std::cout << "warning: " << w << "\n";
  std::cout << out.figures.size() << " figures, " << out.tables.size() << " tables: " << out.index_html << "\n";
  return kExitOk;
}

const bool kReportRegistered = RegisterCommand(
    "report",
    "Regenerate figures (PNG, SVG, CSV, gnuplot script), tables (CSV, Markdown, LaTeX), exports\n"
    "and report/index.html of a calibration folder from DIR/results.json and DIR/evaluation.json.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<ReportCmdOptions>();
      cmd->add_option("dir", o->dir, "calibration folder (from owlcal calibrate)")->required();
      cmd->add_flag("--no-figures", o->no_figures, "write figure data and scripts without running gnuplot");
      cmd->add_flag("--no-exports",
                    o->no_exports,
                    "do not rewrite calibration.yaml, intrinsics.xml, extrinsics.xml and exports/");
      return [o] { return RunReport(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
