// owlcal vor: the vestibulo-ocular reflex experiment (pipeline/vor_study.h). Runs the standard
// `vor` protocol on the robot (the virtual Owl by default) with the eyes on calibrate's fitted
// head (--calib) or the robot file's nominal head, and evaluates it; or evaluates a recorded one
// (--dataset).
#include <filesystem>
#include <iostream>
#include <memory>

#include "apps/command_registry.h"
#include "apps/experiment_recording.h"
#include "apps/robot_factory.h"
#include "apps/robot_options.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/saccade_study.h"
#include "pipeline/vor_study.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/report_data.h"

namespace owlcal::apps {
namespace {

struct VorCmdOptions {
  RobotOptions robot;
  std::string out;
  std::string dataset;
  std::string calib;
  std::string protocol = "vor";
  bool no_figures = false;
  bool quiet = false;
  std::string tracker;
};

int RunVor(const VorCmdOptions& o) {
  const std::optional<std::string> recorded =
      RecordOrUseDataset({"vor",
                          o.protocol,
                          "vor",
                          "the eyes counter-rotate on the robot file's NOMINAL maps",
                          o.robot,
                          o.out,
                          o.dataset,
                          o.calib,
                          o.quiet,
                          o.tracker});
  if (!recorded) return kExitFailed;
  const std::string& dir = *recorded;
  const pipeline::VorStudy study = pipeline::EvaluateVorDataset(dir);
  const std::string page = pipeline::WriteVorStudy(study, o.out, !o.no_figures);
  std::cout << "eyes on the " << study.map << "\n";
  for (const pipeline::VorTrialEye& r : study.results) {
    if (r.condition != "vor") continue;
    std::cout << r.profile << " " << io::FixedText(r.amplitude_deg, 1) << " deg";
    if (r.profile == "sine") std::cout << " at " << io::FixedText(r.frequency_hz, 2) << " Hz";
    std::cout << ", " << models::kEyeNames[r.eye] << " eye: ";
    if (r.status != "ok") std::cout << r.status << " (" << r.reason << ") ";
    if (r.gain.ok) {
      std::cout << "gain " << io::FixedText(r.gain.gain, 3) << " +- " << io::FixedText(r.gain.gain_sigma, 3);
      if (r.profile == "sine")
        std::cout << ", lag " << io::FixedText(r.gain.lag_deg, 1) << " +- " << io::FixedText(r.gain.lag_sigma_deg, 1)
                  << " deg";
      if (r.true_gain && r.true_gain->ok) std::cout << " (truth " << io::FixedText(r.true_gain->gain, 3) << ")";
    } else {
      std::cout << "gain not measured: " << r.gain.reason;
    }
    std::cout << "; RMS slip " << io::FixedText(r.slip.rms_deg_per_s, 2) << " deg/s\n";
  }
  std::cout << study.num_ok << " of " << study.num_trials << " trials ok";
  if (study.num_ok < study.num_trials) std::cout << " (see the report's notes)";
  std::cout << "\nreport: " << page << "\n";
  return study.num_ok == study.num_trials ? kExitOk : kExitFailed;
}

const bool kVorRegistered = RegisterCommand(
    "vor",
    "The vestibulo-ocular reflex: the neck turns through sines at 0.2-1 Hz and a step, once with the eyes\n"
    "held still and once with the eyes counter-rotating on the calibrated neck and eye-pan maps (--calib: a\n"
    "calibrate output folder; without it the robot file's nominal maps, and the report says so). Measures the\n"
    "target's image slip (px, px/s, deg/s; RMS and peak) against the still run, and the VOR gain and phase lag\n"
    "from sines fitted to the eye and neck angles measured from the frames, with sigma; on the virtual Owl also\n"
    "the truth. Runs the standard `vor` protocol (or --protocol FILE) on the robot, or evaluates a recording\n"
    "(--dataset). Writes OUT/tables/vor_*.{csv,md,tex}, OUT/figures/vor_*, OUT/vor.json and OUT/report/index.html;\n"
    "every trial is a row with its status. Exit 1 when a trial failed.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<VorCmdOptions>();
      AddRobotOptions(cmd, &o->robot);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_option("--dataset", o->dataset, "evaluate this recorded vor dataset (no robot)")
          ->check(CLI::ExistingDirectory);
      cmd->add_option("--calib", o->calib, "calibrate output folder whose fitted head the eyes use")
          ->check(CLI::ExistingDirectory);
      cmd->add_option("--protocol", o->protocol, "protocol name or file (default: the standard vor)");
      cmd->add_flag("--no-figures", o->no_figures, "write figure data and scripts without running gnuplot");
      cmd->add_flag("--quiet", o->quiet, "no progress output");
      AddTrackerOption(cmd, &o->tracker);
      return [o] { return RunVor(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
