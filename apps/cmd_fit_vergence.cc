// owlcal fit-vergence CSV --out DIR: eye-pan maps from a vergence log.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "fitting/format.h"
#include "fitting/vergence_log_fit.h"
#include "reports/table.h"
#include "reports/vergence_log_tables.h"
#include "robot/robot_file.h"

namespace owlcal::apps {
namespace {

struct FitVergenceOptions {
  std::string csv;
  std::string out;
  std::string ipd = "auto";
  double ipd_mm = 65;
  double datum_mm = 30;
  bool fix_datum = false;
  double pwm_sigma_us = 1;
  fitting::VergenceColumnRequest columns;
  std::string constants;  // robot file of THIS robot, for the fixed-constant comparison
};

int RunFitVergence(const FitVergenceOptions& a) {
  fitting::VergenceFitOptions o;
  if (a.ipd == "auto")
    o.ipd_mode = fitting::IpdMode::kAuto;
  else if (a.ipd == "fixed")
    o.ipd_mode = fitting::IpdMode::kFixed;
  else if (a.ipd == "free")
    o.ipd_mode = fitting::IpdMode::kFree;
  else
    throw UsageError("--ipd = '" + a.ipd + "': use auto, fixed or free");
  o.ipd_m = a.ipd_mm / 1000;
  o.datum_offset_m = a.datum_mm / 1000;
  o.fit_datum = !a.fix_datum;
  o.pwm_sigma_us = a.pwm_sigma_us;
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  CheckInputOutsideRun(a.out, a.csv, "the vergence log");
  if (!a.constants.empty()) CheckInputOutsideRun(a.out, a.constants, "--constants");
  fitting::VergenceColumns cols;
  const auto rows = fitting::ReadVergenceLogCsv(a.csv, a.columns, &cols);
  // The folder holds this run alone (apps/output_folder.h): a fit that fails leaves no earlier
  // run's fit looking current, and a folder that is not owlcal's is refused before the fit.
  const std::string run_id = StartRun(a.out, [](const std::string& m) { std::cout << m << "\n"; });
  const auto fit = fitting::FitVergenceLog(rows, o);
  fitting::LooSummary loo;  // leave-one-out refits only make sense around a usable fit
  if (fit.summary.usable && !a.constants.empty()) {
    const auto robot = robot::LoadRobotFile(a.constants);
    loo = fitting::LeaveOneOut(rows,
                               o,
                               fit,
                               fitting::FixedConstantVergence::FromRobot(
                                   robot,
                                   a.datum_mm / 1000,
                                   a.constants + " (robot " + robot.name + ": Rx centre " +
                                       std::to_string(robot.servos[models::kRx].centre_us) + " us, Lx centre " +
                                       std::to_string(robot.servos[models::kLx].centre_us) + " us, " +
                                       fitting::FixedOrDash(1 / robot.servos[models::kRx].nominal_deg_per_us, 2) + "/" +
                                       fitting::FixedOrDash(1 / robot.servos[models::kLx].nominal_deg_per_us, 2) +
                                       " us/deg, IPD " + fitting::FixedOrDash(robot.ipd_m * 1000, 1) + " mm, datum " +
                                       fitting::FixedOrDash(a.datum_mm, 0) + " mm)"));
  } else if (fit.summary.usable) {
    loo = fitting::LeaveOneOut(rows, o, fit);
  }
  const std::string md = "Columns used: " + cols.Describe() + ".\n\n" + reports::VergenceReportMarkdown(rows, fit, loo);
  reports::WriteTextFile((std::filesystem::path(a.out) / "vergence_fit.md").string(), md);
  reports::WriteTextFile((std::filesystem::path(a.out) / "vergence_rows.csv").string(),
                         reports::VergenceRowsCsv(rows, fit, loo));
  fitting::CalibrationResult r;
  r.parameters = fit.parameters;
  r.summaries.push_back(fit.summary);
  r.warnings = fit.notes;
  r.inputs = {{"vergence_log", a.csv},
              {"ipd_mode", a.ipd},
              {"pwm_sigma_us", a.pwm_sigma_us},
              {"columns",
               {{"distance", cols.distance_name},
                {"distance_unit", cols.distance_unit},
                {"rx", cols.rx_name},
                {"lx", cols.lx_name},
                {"run", cols.run_name},
                {"ignored", cols.ignored}}},
              {"constants", a.constants}};
  StampRun(run_id, &r);
  r.diagnostics = {{"residual_sigma_us", fit.residual_sigma_us}, {"loo_mean_abs_rel", loo.loo_mean_abs_rel}};
  if (loo.has_fixed) {
    r.diagnostics["fixed_constant_mean_abs_rel"] = loo.fixed_mean_abs_rel;
    r.diagnostics["fixed_constant_source"] = loo.fixed_source;
  }
  fitting::WriteResultJson(r, (std::filesystem::path(a.out) / "results.json").string());
  std::cout << md << "\nwrote " << a.out << "/{vergence_fit.md, vergence_rows.csv, results.json}\n";
  if (!fit.summary.usable) {
    std::cerr << "fit-vergence: the fit is NOT usable (" << fit.summary.termination << ")";
    for (const std::string& n : fit.notes) std::cerr << "; " << n;
    std::cerr << "\n";
    return kExitFailed;
  }
  return kExitOk;
}

const bool kFitVergenceRegistered = RegisterCommand(
    "fit-vergence",
    "Fit each eye's pan centre and us/deg scale (and the distance datum) from a vergence log CSV\n"
    "(run, a true distance, Rx, Lx), with sigma and leave-one-out range error; with --constants ROBOT-FILE,\n"
    "compared with that robot's fixed constants. A header with more than one distance-like column is refused\n"
    "unless --distance-column names the true distance; the columns used are reported.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitVergenceOptions>();
      cmd->add_option("csv", o->csv, "vergence log: header with distance_cm|distance_mm, Rx, Lx, optional run")
          ->required()
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder (vergence_fit.md, vergence_rows.csv, results.json)")->required();
      cmd->add_option("--ipd", o->ipd, "IPD: auto (free only if the data determine it), fixed, free")
          ->capture_default_str();
      cmd->add_option("--ipd-mm", o->ipd_mm, "IPD when fixed / start when free [mm]")->capture_default_str();
      cmd->add_option("--datum-mm", o->datum_mm, "distance datum in front of the eye centres [mm] (start or fixed)")
          ->capture_default_str();
      cmd->add_flag("--fix-datum", o->fix_datum, "do not fit the datum");
      cmd->add_option("--pwm-sigma-us", o->pwm_sigma_us, "prior sigma of one logged PWM [us]")->capture_default_str();
      cmd->add_option("--distance-column",
                      o->columns.distance,
                      "header name of the TRUE distance (needed when several columns look like distances)");
      cmd->add_option("--distance-unit", o->columns.distance_unit, "m, cm or mm (default: the column name's suffix)");
      cmd->add_option("--rx-column", o->columns.rx, "header name of the right-eye pan PWM (default Rx, Rx_us, Rx_pwm)");
      cmd->add_option("--lx-column", o->columns.lx, "header name of the left-eye pan PWM (default Lx, Lx_us, Lx_pwm)");
      cmd->add_option("--run-column", o->columns.run, "header name of the run id (default run; absent = one run)");
      cmd->add_option("--constants",
                      o->constants,
                      "robot file (data/robots/guide-owl.yaml form) of THIS robot: its Rx/Lx centres, deg_per_us, "
                      "directions and IPD are the fixed-constant method compared with the fit")
          ->check(CLI::ExistingFile);
      return [o] { return RunFitVergence(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
