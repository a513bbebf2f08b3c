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
    const fitting::CalibrationRun run = reports::ReadReportData(e.calib);
    ro.calibration = pipeline::ControllerCalibration(run, e.calib);
    if (!e.quiet) std::cout << "eyes on the calibration in " << ro.calibration->source << "\n";
  } else if (!e.quiet) {
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

}  // namespace owlcal::apps
