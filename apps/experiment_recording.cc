#include "apps/experiment_recording.h"

#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "apps/robot_factory.h"
#include "pipeline/saccade_study.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/report_data.h"

namespace owlcal::apps {

std::optional<std::string> RecordOrUseDataset(const ExperimentRecording& e) {
  if (!e.dataset.empty() && !e.calib.empty())
    throw UsageError("--calib is for a new recording; a recorded --dataset says which maps it used");
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
  const protocols::Protocol p = protocols::LoadProtocolFile(protocols::ResolveProtocolPath(e.protocol));
  const protocols::RunSummary s = protocols::RunProtocols({p}, *robot, ro);
  if (s.status != "complete") {
    std::cerr << "owlcal " << e.command << ": " << s.status << ": " << s.message << "\n"
              << "the dataset in " << dir << " is closed; evaluate what it holds with --dataset " << dir << "\n";
    return std::nullopt;
  }
  return dir;
}

}  // namespace owlcal::apps
