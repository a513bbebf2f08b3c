// owlcal calibrate [--robot sim|HOST] [--robot-truth FILE] [--seed N] --out DIR: the main job.
// Records one dataset per protocol of the standard suite under DIR/datasets/, runs the
// calibration pipeline on them (pipeline/calibrate_pipeline.h: intrinsics + stereo, head,
// evaluations, truth on the virtual Owl), then records the protocols that use the calibration
// (saccade: pipeline/saccade_study.h) and evaluates them, and writes DIR/results.json, DIR/evaluation.json,
// DIR/calibration.yaml, DIR/intrinsics.xml and extrinsics.xml (the course's files, mm),
// DIR/exports/, DIR/figures/, DIR/tables/ and DIR/report/index.html (apps/calibration_output.h).
// `owlcal fit-datasets DIR` runs the same pipeline again on the recorded datasets.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <map>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/robot_factory.h"
#include "apps/robot_options.h"
#include "owlcal_version.h"
#include "pipeline/calibrate_pipeline.h"
#include "pipeline/saccade_study.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct CalibrateOptions {
  RobotOptions robot;
  std::string out;
  std::vector<std::string> protocols;  // default: the standard suite
  bool non_interactive = false;
  bool no_figures = false;
  bool quiet = false;
  std::string lens_model = "auto";
};

int RunCalibrate(const CalibrateOptions& o) {
  if (o.out.empty()) throw UsageError("--out DIR is required");
  if (fs::exists(o.out + "/results.json")) throw UsageError(o.out + " already holds a calibration (results.json); choose a new --out");
  const Progress progress("calibrate", o.quiet);
  fs::create_directories(o.out);
  std::vector<std::string> names = o.protocols.empty() ? protocols::StandardProtocolNames() : o.protocols;

  std::unique_ptr<robot::RobotInterface> robot = MakeRobot(o.robot.robot, o.robot.Factory());
  const models::RobotConfig config = robot->Config();
  progress("robot: " + robot->Describe());

  nlohmann::json settings = {{"command", "owlcal calibrate"},  {"robot", o.robot.robot},
                              {"robot_file", o.robot.robot_file}, {"robot_truth", o.robot.robot_truth},
                              {"scene", o.robot.scene},           {"seed", o.robot.seed},
                              {"http_port", o.robot.http_port},   {"protocols", names},
                              {"non_interactive", o.non_interactive}, {"no_figures", o.no_figures},
                              {"owlcal_version", OWLCAL_VERSION}};
  std::vector<std::string> warnings;
  std::optional<sim::RobotTruth> truth;
  if (auto* owl = dynamic_cast<sim::VirtualOwl*>(robot.get())) truth = owl->Truth();

  // 1) Record one dataset per protocol. A protocol with a saccade step needs the calibration:
  //    it is recorded after the fit (3).
  std::atomic<bool>* stop = protocols::InstallStopSignals();
  std::map<std::string, std::string> dataset;
  nlohmann::json run_info = nlohmann::json::object();
  auto record = [&](const protocols::Protocol& p, const std::string& dir,
                    const std::optional<protocols::CalibratedMaps>& calibration) {
    progress("protocol " + p.name + " -> " + dir);
    protocols::RunOptions ro;
    ro.out_dir = dir;
    o.robot.FillRunOptions(&ro);
    ro.progress = nullptr;
    // A real robot: a person places the targets, prompted on the terminal (the prompt and the
    // answer are recorded in placements.csv); piped or --non-interactive: the protocol's poses
    // are assumed, and the dataset says so.
    ro.interactive = !o.robot.IsSim() && !o.non_interactive && ::isatty(STDIN_FILENO);
    ro.stop_flag = stop;
    ro.calibration = calibration;
    const protocols::RunSummary s = protocols::RunProtocols({p}, *robot, ro);
    run_info[p.name] = {{"status", s.status}, {"frames", s.num_frames}, {"clamped", s.num_clamped},
                        {"robot_clock_s", s.elapsed_s}, {"message", s.message}};
    // Step-response and latency trials keep servo traces and tables, not camera frames.
    progress("  " + s.status + ", " +
             (s.num_frames > 0 ? std::to_string(s.num_frames) + " frames" : "no frames kept (tables only)") + ", " +
             std::to_string(s.num_clamped) + " clamped commands");
    if (s.status == "aborted") throw std::runtime_error("stopped by the user; datasets so far are in " + o.out);
    if (s.status != "complete") warnings.push_back("protocol " + p.name + ": " + s.status + ": " + s.message);
  };
  std::vector<std::pair<protocols::Protocol, std::string>> after_fit;
  for (const std::string& name : names) {
    const std::string dir = o.out + "/datasets/" + fs::path(name).stem().string();
    protocols::Protocol p;
    try {
      p = protocols::LoadProtocolFile(protocols::ResolveProtocolPath(name));
    } catch (const protocols::ProtocolError& e) {
      throw UsageError(e.what());
    }
    const bool needs_fit = std::any_of(p.steps.begin(), p.steps.end(), [](const protocols::Step& st) {
      return st.kind() == protocols::StepKind::kSaccade;
    });
    if (needs_fit) {
      after_fit.emplace_back(p, dir);
      continue;
    }
    record(p, dir, std::nullopt);
    dataset[p.name] = dir;
  }
  settings["lens_model"] = o.lens_model;

  // 2) Everything after recording: the pipeline.
  pipeline::CalibratePipelineOptions po;
  po.config = config;
  if (truth) {
    po.truth = truth->HeadModel();
    po.latency_truth = LatencyTruthOf(*truth);
    po.fps = truth->stream.fps;
    for (int i = 0; i < models::kNumServos; ++i) po.truth_slew_deg_per_s[i] = truth->servos[i].slew_deg_per_s;
    po.truth_latency_s = truth->stream.latency_ms / 1000.0;
  }
  po.progress = progress;
  std::string why;
  if (!pipeline::SetLensModel(o.lens_model, &po, &why)) throw UsageError(why);
  fitting::CalibrationRun d = pipeline::CalibrateFromDatasets(dataset, po);

  // 3) The protocols that use the calibration (saccades), then their evaluation.
  for (const auto& [p, dir] : after_fit) {
    record(p, dir, pipeline::ControllerCalibration(d, "this calibrate run's head fit and step-response motion fit"));
    dataset[p.name] = dir;
    pipeline::AddSaccadeEvaluation(dir, po, &d);
  }
  d.result.inputs["datasets"] = dataset;
  settings["runs"] = run_info;
  d.result.warnings.insert(d.result.warnings.begin(), warnings.begin(), warnings.end());
  d.settings = settings;
  d.result.inputs["command"] = settings;

  // 4) Files.
  WriteCalibrationFolder(&d, o.out, !o.no_figures, progress);
  return kExitOk;
}

const bool kRegistered = RegisterCommand(
    "calibrate",
    "The main job: run the standard suite, fit, evaluate and write the report folder.\n"
    "With no --robot it uses the in-process virtual Owl. Produces DIR/results.json (every\n"
    "parameter with value, sigma, unit and truth), DIR/calibration.yaml (OpenCV, metres),\n"
    "DIR/intrinsics.xml + extrinsics.xml (the course's files, mm), DIR/exports/ (ROS, Kalibr,\n"
    "mrcal, owl-pwm.h), DIR/figures/, DIR/tables/, DIR/report/index.html and the recorded\n"
    "datasets in DIR/datasets/.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CalibrateOptions>();
      AddRobotOptions(cmd, &o->robot);
      cmd->add_flag("--non-interactive", o->non_interactive,
                    "real robot: do not prompt; assume targets are placed as the protocols say");
      cmd->add_option("--protocols", o->protocols, "protocols to run instead of the standard suite");
      cmd->add_option("--out", o->out, "report folder to create")->required();
      AddCalibrationOutputOptions(cmd, &o->no_figures, &o->quiet, &o->lens_model);
      return [o] { return RunCalibrate(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
