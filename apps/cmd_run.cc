// owlcal run PROTOCOL... --robot sim|HOST --out DATASET: executes experiment protocols and
// records a dataset (protocols/runner.h, protocols/dataset.h).
#include <unistd.h>

#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "apps/robot_factory.h"
#include "apps/robot_options.h"
#include "protocols/live_feedback.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/link_commands.h"

namespace owlcal::apps {
namespace {

struct RunCmdOptions {
  std::vector<std::string> protocols;
  RobotOptions robot;
  std::string out;
  bool dry_run = false;
  bool resume = false;
  bool non_interactive = false;
  bool quiet = false;
  int live_port = -1;  // -1: no live feedback
};

int RunRun(const RunCmdOptions& o) {
  if (o.protocols.empty())
    throw UsageError("give at least one protocol (a file or a standard name: " + [] {
      std::string s;
      for (const auto& n : protocols::StandardProtocolNames()) s += (s.empty() ? "" : ", ") + n;
      return s;
    }() + ")");
  if (!o.dry_run && o.out.empty()) throw UsageError("--out DATASET is required (except with --dry-run)");
  std::vector<protocols::Protocol> loaded;
  for (const std::string& p : o.protocols) {
    try {
      loaded.push_back(protocols::LoadProtocolFile(protocols::ResolveProtocolPath(p)));
    } catch (const protocols::ProtocolError& e) {
      throw UsageError(e.what());
    }
  }
  protocols::RunOptions ro;
  ro.out_dir = o.out;
  ro.dry_run = o.dry_run;
  ro.resume = o.resume;
  o.robot.FillRunOptions(&ro);
  ro.progress = o.quiet ? nullptr : &std::cout;
  ro.interactive = !o.robot.IsSim() && !o.non_interactive && ::isatty(STDIN_FILENO);
  if (o.dry_run) {
    // Nothing moves and nothing connects: plan against the robot file's limits.
    models::RobotConfig config = robot::RobotConfigOrDefault(o.robot.robot_file);
    if (o.robot.IsSim()) config = MakeRobot("sim", o.robot.Factory())->Config();
    int64_t clamped = 0;
    for (const std::string& line : protocols::PlanRun(loaded, config, &clamped)) std::cout << line << "\n";
    return kExitOk;
  }
  std::unique_ptr<robot::RobotInterface> robot = MakeRobot(o.robot.robot, o.robot.Factory());
  std::unique_ptr<protocols::LiveFeedback> live;
  if (o.live_port >= 0) {
    protocols::LiveFeedbackOptions lo;
    lo.port = o.live_port;
    live = std::make_unique<protocols::LiveFeedback>(lo);
    std::cout << "live capture feedback: " << live->Url() << " (one frame: http://127.0.0.1:" << live->Port()
              << "/frame.jpg)" << std::endl;
    ro.on_detection = [&live](const protocols::LiveDetection& d) { live->Update(d); };
  }
  ro.stop_flag = protocols::InstallStopSignals();
  const protocols::RunSummary s = protocols::RunProtocols(loaded, *robot, ro);
  if (s.status != "complete") {
    std::cerr << "owlcal run: " << s.status << ": " << s.message << "\n"
              << "the dataset in " << o.out << " is closed and usable; continue with --resume\n";
    return kExitFailed;
  }
  std::cout << "dataset: " << o.out << " (" << s.num_frames << " frames)\n";
  return kExitOk;
}

const bool kRunRegistered = RegisterCommand(
    "run",
    "Run experiment protocols on a robot and record a dataset.\n"
    "Consumes protocol files (YAML; or standard names: limits, alignment, intrinsics, stereo,\n"
    "servo_sweep, vergence, step_response, latency); produces DATASET/ (manifest.json, frames/,\n"
    "frames.csv, placements.csv, steps.csv, events.log and measurement tables). Every command\n"
    "is clamped to the robot file's limits; Ctrl-C, SIGTERM or SIGHUP parks the head and closes the dataset as "
    "aborted.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<RunCmdOptions>();
      cmd->add_option("protocols", o->protocols, "protocol files or standard protocol names")->required();
      AddRobotOptions(cmd, &o->robot);
      cmd->add_option("--out", o->out, "dataset folder to create (or continue with --resume)");
      cmd->add_flag("--dry-run", o->dry_run, "print the planned commands checked against the limits; move nothing");
      cmd->add_flag("--resume", o->resume, "continue an interrupted run in --out");
      cmd->add_flag("--non-interactive",
                    o->non_interactive,
                    "real robot: do not prompt; assume targets are placed as the protocol says");
      cmd->add_flag("--quiet", o->quiet, "no progress output");
      cmd->add_option("--live-port",
                      o->live_port,
                      "serve live capture feedback (detection overlay, coverage bars X/Y/Size/Skew, missing views)\n"
                      "as MJPEG on 127.0.0.1:PORT (0: any free port, printed)")
          ->check(CLI::Range(0, 65535));
      return [o] { return RunRun(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
