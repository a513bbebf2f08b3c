// owlcal fit-head OBS --out DIR: the head problem on a servo-sweep
// observation file: servo maps, camera mounts, eye centres and IPD, neck map, with sigma and
// the parameters the data cannot determine named (fitting/head_fit.h).
// Consumes: observations CSV (calib/observation_io.h), optional robot file (robot/robot_file.h,
// default: the guide's robot) and optional intrinsics result JSON (fitting/result.h; its
// cameras are held fixed unless --fit-intrinsics). Produces DIR/head_result.json.
#include <filesystem>
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "calib/observation.h"
#include "calib/observation_io.h"
#include "fitting/calibration_folder.h"
#include "fitting/head_fit.h"
#include "fitting/result.h"
#include "models/head_model.h"
#include "protocols/placement_views.h"
#include "robot/robot_file.h"

namespace owlcal::apps {
namespace {

struct FitHeadArgs {
  std::string observations;
  std::string out;
  std::string robot_file;
  std::string intrinsics_json;
  double sigma_px = 0;  // 0: measured from the residuals (HeadFitOptions::estimate_corner_sigma)
  double min_sigma_px = 0.0;
  double bias_factor = 1.4;  // measured sigma x this for the detector bias (as owlcal calibrate)
  bool fit_intrinsics = false;
  bool linear = false;
};

int RunFitHead(const FitHeadArgs& a) {
  fitting::HeadFitOptions o;
  if (a.sigma_px < 0) throw UsageError("--sigma-px must be >= 0 (0: measure it from the residuals)");
  o.estimate_corner_sigma = a.sigma_px == 0;
  if (a.sigma_px > 0) o.corner_sigma_px = a.sigma_px;
  o.min_corner_sigma_px = a.min_sigma_px;
  if (o.estimate_corner_sigma) {
    o.measured_sigma_factor = a.bias_factor;
    o.hysteresis_sigma_floor_us = 0.01;  // servo lag is not modelled (see owlcal calibrate)
  }
  o.fit_intrinsics = a.fit_intrinsics;
  o.fit_nonlinear = !a.linear;
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  const models::RobotConfig robot =
      a.robot_file.empty() ? models::DefaultRobotConfig() : robot::LoadRobotFile(a.robot_file);
  models::HeadModel init = models::NominalHeadModel(robot);
  if (!a.intrinsics_json.empty()) {
    fitting::CheckOneRunOfPath(a.intrinsics_json);  // a calibration folder's results.json: of one run
    const fitting::CalibrationResult prior = fitting::ReadResultJson(a.intrinsics_json);
    for (int e = 0; e < 2; ++e) {
      if (!prior.cameras[e])
        throw UsageError(a.intrinsics_json + ": no " + models::kEyeNames[e] + " camera in the result");
      init.intrinsics[e] = *prior.cameras[e];
    }
  } else if (!a.fit_intrinsics) {
    std::cerr << "owlcal fit-head: no --intrinsics given: nominal intrinsics (f = 585 px, no distortion) are held "
                 "fixed; results are only as good as that guess (or use --fit-intrinsics)\n";
  }
  std::vector<calib::View> views = calib::GroupIntoViews(calib::ReadObservationsCsv(a.observations));
  // A dataset's observations.csv: each placement of one target is its own fixed board.
  const std::filesystem::path frames_dir = std::filesystem::path(a.observations).parent_path();
  if (std::filesystem::exists(frames_dir / "frames.csv"))
    views = protocols::SplitViewsByPlacement(std::move(views), protocols::ReadFramesCsv(frames_dir.string()));
  fitting::HeadFit fit = fitting::FitHead(views, robot, init, o);
  fit.result.inputs["observations"] = a.observations;
  if (!a.intrinsics_json.empty()) fit.result.inputs["intrinsics"] = a.intrinsics_json;
  std::filesystem::create_directories(a.out);
  const std::string path = (std::filesystem::path(a.out) / "head_result.json").string();
  fitting::WriteResultJson(fit.result, path);
  for (const std::string& w : fit.result.warnings) std::cout << "warning: " << w << "\n";
  if (!fit.ok) {
    std::cerr << "owlcal fit-head: " << fit.message << "\n";
    return kExitFailed;
  }
  for (const fitting::Parameter& p : fit.result.parameters) {
    if (p.determined) std::cout << p.name << " = " << p.value << " +- " << p.sigma << " " << p.unit << "\n";
  }
  std::cout << fit.message << "\nwrote " << path << "\n";
  return kExitOk;
}

const bool kFitHeadRegistered = RegisterCommand(
    "fit-head",
    "Fit servo maps, camera mounts, eye centres/IPD and the neck map from servo-sweep observations of fixed boards",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitHeadArgs>();
      cmd->add_option("observations", o->observations, "observations CSV (owlcal detect)")
          ->required()
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder (head_result.json)")->required();
      cmd->add_option("--robot", o->robot_file, "robot file (default: the guide's robot)")->check(CLI::ExistingFile);
      cmd->add_option("--intrinsics", o->intrinsics_json, "result JSON with both cameras (held fixed)")
          ->check(CLI::ExistingFile);
      cmd->add_option(
             "--sigma-px", o->sigma_px, "corner noise used to whiten [px]; 0 = measured per eye from the residuals")
          ->capture_default_str();
      cmd->add_option("--min-sigma-px", o->min_sigma_px, "floor of the measured corner noise (detector bias) [px]")
          ->capture_default_str();
      cmd->add_option("--bias-factor",
                      o->bias_factor,
                      "with --sigma-px 0: the measured noise is multiplied by this for the detector's bias")
          ->capture_default_str();
      cmd->add_flag("--fit-intrinsics", o->fit_intrinsics, "fit the intrinsics jointly");
      cmd->add_flag("--linear", o->linear, "hold the servo maps' quadratic and cubic terms at 0");
      return [o] { return RunFitHead(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
