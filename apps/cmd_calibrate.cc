// owlcal calibrate [--robot sim|HOST] [--robot-truth FILE] [--seed N] --out DIR: the main job,
// pipeline::Calibrate (pipeline/calibrate.h) on the chosen robot, then the calibration folder
// (apps/calibration_output.h). `owlcal fit-datasets DIR` refits what it recorded. --dry-run prints the
// person's work and the robot's time per protocol (pipeline/calibrate_work.h) and moves nothing.
#include <unistd.h>

#include <filesystem>
#include <iostream>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "apps/robot_factory.h"
#include "apps/robot_options.h"
#include "owlcal_version.h"
#include "pipeline/calibrate.h"
#include "pipeline/calibrate_work.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct CalibrateOptions {
  RobotOptions robot;
  std::string out;
  std::vector<std::string> protocols;  // default: the standard suite
  bool non_interactive = false;
  bool dry_run = false;
  bool no_figures = false;
  bool quiet = false;
  std::string lens_model = "auto";
};

// --dry-run: the person's work and the robot's time per protocol, planned on the robot file's
// limits (pipeline/calibrate_work.h); nothing moves and nothing connects.
int PlanCalibrate(const CalibrateOptions& o) {
  models::RobotConfig config = robot::RobotConfigOrDefault(o.robot.robot_file);
  if (o.robot.IsSim()) config = MakeRobot("sim", o.robot.Factory())->Config();
  std::vector<protocols::Protocol> loaded;
  try {
    for (const std::string& name : o.protocols.empty() ? protocols::StandardProtocolNames() : o.protocols)
      loaded.push_back(protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name)));
    int64_t clamped = 0;
    protocols::PlanRun(loaded, config, &clamped);
    std::cout << "owlcal calibrate --dry-run on '" << config.name
              << "' (nothing moves): per protocol in the order calibrate records them, the target placements a "
                 "person makes (a target left where it is counts once) and the robot's time\n";
    for (const std::string& line : protocols::WorkLines(pipeline::PlanCalibrateWork(loaded, config), true))
      std::cout << line << "\n";
    std::cout << "robot time: the open-loop steps at 30 fps; the protocols after limits run on the limits it "
                 "measures. "
              << clamped
              << " planned commands would be clamped to the robot's limits ('owlcal run NAME --dry-run' "
                 "lists them)\n";
  } catch (const protocols::ProtocolError& e) {
    throw UsageError(e.what());
  }
  return kExitOk;
}

int RunCalibrate(const CalibrateOptions& o) {
  if (o.dry_run) return PlanCalibrate(o);
  if (o.out.empty()) throw UsageError("--out DIR is required (except with --dry-run)");
  if (fs::exists(o.out + "/results.json"))
    throw UsageError(o.out + " already holds a calibration (results.json); choose a new --out");
  const Progress progress("calibrate", o.quiet);
  pipeline::CalibrateOptions co;
  co.out = o.out;
  co.protocols = o.protocols;
  std::string why;
  if (!pipeline::SetLensModel(o.lens_model, &co.fit, &why)) throw UsageError(why);
  co.robot = o.robot.Record();
  // A real robot: a person places the targets, prompted on the terminal (the prompt and the
  // answer are recorded in placements.csv); piped or --non-interactive: the protocols' poses are
  // assumed, and the dataset says so.
  co.interactive = !o.robot.IsSim() && !o.non_interactive && ::isatty(STDIN_FILENO);
  co.stop_flag = protocols::InstallStopSignals();
  co.progress = progress;
  co.fit.warning = PrintWarning;
  co.settings = {{"command", "owlcal calibrate"},
                 {"robot", o.robot.robot},
                 {"robot_file", o.robot.robot_file},
                 {"robot_truth", o.robot.robot_truth},
                 {"scene", o.robot.scene},
                 {"seed", o.robot.seed},
                 {"http_port", o.robot.http_port},
                 {"protocols", o.protocols.empty() ? protocols::StandardProtocolNames() : o.protocols},
                 {"non_interactive", o.non_interactive},
                 {"no_figures", o.no_figures},
                 {"lens_model", o.lens_model},
                 {"owlcal_version", OWLCAL_VERSION}};
  std::unique_ptr<robot::RobotInterface> robot = MakeRobot(o.robot.robot, o.robot.Factory());
  const std::string run_id = StartRun(o.out, progress);
  evaluation::CalibrationRun run;
  try {
    run = pipeline::Calibrate(*robot, co);
  } catch (const protocols::ProtocolError& e) {
    throw UsageError(e.what());
  }
  WriteCalibrationFolder(&run, run_id, o.out, !o.no_figures, progress);
  return kExitOk;
}

const bool kCalibrateRegistered =
    RegisterCommand("calibrate",
                    "The main job: run the standard suite, fit, evaluate and write the report folder.\n"
                    "With no --robot it uses the in-process virtual Owl. Produces DIR/results.json (every\n"
                    "parameter with value, sigma, unit and truth), DIR/calibration.yaml (OpenCV, metres),\n"
                    "DIR/intrinsics.xml + extrinsics.xml (the course's files, mm), DIR/exports/ (ROS, Kalibr,\n"
                    "mrcal, owl-pwm.h), DIR/figures/, DIR/tables/, DIR/report/index.html and the recorded\n"
                    "datasets in DIR/datasets/.",
                    [](CLI::App* cmd) {
                      auto o = std::make_shared<CalibrateOptions>();
                      AddRobotOptions(cmd, &o->robot);
                      cmd->add_flag("--non-interactive",
                                    o->non_interactive,
                                    "real robot: do not prompt; assume targets are placed as the protocols say");
                      cmd->add_option("--protocols", o->protocols, "protocols to run instead of the standard suite");
                      cmd->add_flag("--dry-run",
                                    o->dry_run,
                                    "print per protocol the placements a person makes and the robot's time; move "
                                    "nothing");
                      cmd->add_option("--out", o->out, "report folder to create (required unless --dry-run)");
                      AddCalibrationOutputOptions(cmd, &o->no_figures, &o->quiet, &o->lens_model);
                      return [o] { return RunCalibrate(*o); };
                    });

}  // namespace
}  // namespace owlcal::apps
