// owlcal fit-vergence CSV --out DIR: eye-pan maps from a vergence log (issue 7, item 4).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "fitting/vergence_log_fit.h"

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
};

void WriteText(const std::filesystem::path& p, const std::string& text) {
  std::ofstream f(p);
  if (!f) throw std::runtime_error(p.string() + ": cannot write");
  f << text;
}

int RunFitVergence(const FitVergenceOptions& a) {
  fitting::VergenceFitOptions o;
  if (a.ipd == "auto") o.ipd_mode = fitting::IpdMode::kAuto;
  else if (a.ipd == "fixed") o.ipd_mode = fitting::IpdMode::kFixed;
  else if (a.ipd == "free") o.ipd_mode = fitting::IpdMode::kFree;
  else throw UsageError("--ipd = '" + a.ipd + "': use auto, fixed or free");
  o.ipd_m = a.ipd_mm / 1000;
  o.datum_offset_m = a.datum_mm / 1000;
  o.fit_datum = !a.fix_datum;
  o.pwm_sigma_us = a.pwm_sigma_us;
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  const auto rows = fitting::ReadVergenceLogCsv(a.csv);
  const auto fit = fitting::FitVergenceLog(rows, o);
  const auto loo = fitting::LeaveOneOut(rows, o, fit, fitting::FixedConstantVergence{});
  std::filesystem::create_directories(a.out);
  const std::string md = fitting::VergenceReportMarkdown(rows, fit, loo);
  WriteText(std::filesystem::path(a.out) / "vergence_fit.md", md);
  WriteText(std::filesystem::path(a.out) / "vergence_rows.csv", fitting::VergenceRowsCsv(rows, fit, loo));
  fitting::CalibrationResult r;
  r.parameters = fit.parameters;
  r.summaries.push_back(fit.summary);
  r.warnings = fit.notes;
  r.inputs = {{"vergence_log", a.csv}, {"ipd_mode", a.ipd}, {"pwm_sigma_us", a.pwm_sigma_us}};
  r.diagnostics = {{"residual_sigma_us", fit.residual_sigma_us},
                   {"loo_mean_abs_rel", loo.loo_mean_abs_rel},
                   {"fixed_constant_mean_abs_rel", loo.fixed_mean_abs_rel}};
  fitting::WriteResultJson(r, (std::filesystem::path(a.out) / "results.json").string());
  std::cout << md << "\nwrote " << a.out << "/{vergence_fit.md, vergence_rows.csv, results.json}\n";
  return fit.summary.usable ? kExitOk : kExitFailed;
}

const bool kRegistered = RegisterCommand(
    "fit-vergence",
    "Fit each eye's pan centre and us/deg scale (and the distance datum) from a vergence log CSV "
    "(run, distance_cm, Rx, Lx), with sigma and leave-one-out range error vs the course's fixed constants",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitVergenceOptions>();
      cmd->add_option("csv", o->csv, "vergence log: header with distance_cm|distance_mm, Rx, Lx, optional run")
          ->required()->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder (vergence_fit.md, vergence_rows.csv, results.json)")->required();
      cmd->add_option("--ipd", o->ipd, "IPD: auto (free only if the data determine it), fixed, free")
          ->capture_default_str();
      cmd->add_option("--ipd-mm", o->ipd_mm, "IPD when fixed / start when free [mm]")->capture_default_str();
      cmd->add_option("--datum-mm", o->datum_mm, "distance datum in front of the eye centres [mm] (start or fixed)")
          ->capture_default_str();
      cmd->add_flag("--fix-datum", o->fix_datum, "do not fit the datum");
      cmd->add_option("--pwm-sigma-us", o->pwm_sigma_us, "prior sigma of one logged PWM [us]")->capture_default_str();
      return [o] { return RunFitVergence(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
