#include "apps/experiment_recording.h"

#include <iostream>
#include <memory>
#include <variant>

#include <CLI/CLI.hpp>

#include "apps/command_registry.h"
#include "apps/robot_factory.h"
#include "pipeline/saccade_study.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/report_data.h"

namespace owlcal::apps {

void AddTrackerOption(CLI::App* cmd, std::string* tracker) {
  cmd->add_option("--tracker",
                  *tracker,
                  "how every step locates the target: 'disc' (the fixation disc detector, checked against the "
                  "disc's first look where the step does so) or 'lk' (Lucas-Kanade, seeded by the disc detector); "
                  "default: as the protocol says (`locator:`)")
      ->check(CLI::IsMember({"disc", "lk"}));
}

int SetProtocolLocator(protocols::Protocol* p, protocols::Locator kind) {
  int n = 0;
  for (protocols::Step& step : p->steps)
    std::visit(
        [&](auto& s) {
          if constexpr (requires { s.locator; }) {
            s.locator = kind;
            ++n;
          }
          if constexpr (requires { s.loop.locator; }) {
            s.loop.locator = kind;
            ++n;
          }
        },
        step.params);
  return n;
}

std::optional<std::string> RecordOrUseDataset(const ExperimentRecording& e) {
  if (!e.dataset.empty() && !e.calib.empty())
    throw UsageError("--calib is for a new recording; a recorded --dataset says which maps it used");
  if (!e.dataset.empty() && !e.tracker.empty())
    throw UsageError("--tracker is for a new recording; a recorded --dataset was located as it was");
  if (!e.dataset.empty()) return e.dataset;
  const std::string dir = e.out + "/datasets/" + e.dataset_name;
  protocols::RunOptions ro;
  ro.out_dir = dir;
  e.robot.FillRunOptions(&ro);
  ro.progress = e.quiet ? nullptr : &std::cout;
  ro.stop_flag = protocols::InstallStopSignals();
  if (!e.calib.empty()) {
    const evaluation::CalibrationRun run = reports::ReadReportData(e.calib);
    ro.calibration = pipeline::ControllerCalibration(run, e.calib);
    if (!e.quiet) std::cout << "eyes on the calibration in " << ro.calibration->source << "\n";
  } else if (!e.quiet && !e.nominal_note.empty()) {
    std::cout << "no --calib: " << e.nominal_note << "\n";
  }
  std::unique_ptr<robot::RobotInterface> robot = MakeRobot(e.robot.robot, e.robot.Factory());
  protocols::Protocol p = protocols::LoadProtocolFile(protocols::ResolveProtocolPath(e.protocol));
  if (!e.tracker.empty()) {
    const int n = SetProtocolLocator(&p, e.tracker == "lk" ? protocols::Locator::kLk : protocols::Locator::kFixation);
    if (!e.quiet) std::cout << "--tracker " << e.tracker << ": " << n << " step(s) locate the target with it\n";
  }
  const protocols::RunSummary s = protocols::RunProtocols({p}, *robot, ro);
  if (s.status != "complete") {
    std::cerr << "owlcal " << e.command << ": " << s.status << ": " << s.message << "\n"
              << "the dataset in " << dir << " is closed; evaluate what it holds with --dataset " << dir << "\n";
    return std::nullopt;
  }
  return dir;
}

namespace {

struct ExperimentOptions {
  RobotOptions robot;
  std::string out, dataset, calib, images, protocol, tracker;
  bool no_figures = false;
  bool quiet = false;
};

int RunExperiment(const ExperimentCommand& c, const ExperimentOptions& o) {
  ExperimentInput in;
  in.out = o.out;
  in.figures = !o.no_figures;
  if (!o.images.empty()) {
    if (!o.dataset.empty()) throw UsageError("give --dataset or --images, not both");
    in.images = o.images;
    return c.evaluate(in);
  }
  const std::string dataset_name = c.protocol;  // OUT/datasets/<standard protocol>, whatever --protocol says
  const std::optional<std::string> recorded = RecordOrUseDataset(
      {c.name, o.protocol, dataset_name, c.nominal_note, o.robot, o.out, o.dataset, o.calib, o.quiet, o.tracker});
  if (!recorded) return kExitFailed;
  in.dataset = *recorded;
  return c.evaluate(in);
}

}  // namespace

bool RegisterExperiment(ExperimentCommand c) {
  const auto command = std::make_shared<const ExperimentCommand>(std::move(c));
  return RegisterCommand(command->name, command->help, [command](CLI::App* cmd) {
    auto o = std::make_shared<ExperimentOptions>();
    o->protocol = command->protocol;
    AddRobotOptions(cmd, &o->robot);
    cmd->add_option("--out", o->out, "output folder")->required();
    cmd->add_option("--dataset", o->dataset, "evaluate this recorded " + command->name + " dataset (no robot)")
        ->check(CLI::ExistingDirectory);
    if (!command->images_help.empty())
      cmd->add_option("--images", o->images, command->images_help)->check(CLI::ExistingFile);
    else
      cmd->add_option(
          "--protocol", o->protocol, "protocol name or file (default: the standard " + command->protocol + ")");
    if (!command->nominal_note.empty())
      cmd->add_option("--calib", o->calib, "calibrate output folder whose fitted head the eyes use")
          ->check(CLI::ExistingDirectory);
    cmd->add_flag("--no-figures", o->no_figures, "write figure data and scripts without running gnuplot");
    cmd->add_flag("--quiet", o->quiet, "no progress output");
    if (!command->nominal_note.empty()) AddTrackerOption(cmd, &o->tracker);
    return [command, o] { return RunExperiment(*command, *o); };
  });
}

}  // namespace owlcal::apps
