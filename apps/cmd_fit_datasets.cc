// owlcal fit-datasets DIR --out NEW: re-fits a recorded calibration folder (what `owlcal
// calibrate` left in DIR/datasets/) with no robot: the same pipeline as calibrate
// (pipeline/calibrate_pipeline.h) with the robot configuration and, on the virtual Owl, the
// truth the datasets' manifests recorded. With the default options every results.json value
// and sigma is the one calibrate wrote; the options below change the fit.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <unistd.h>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "owlcal_version.h"
#include "pipeline/calibrate_pipeline.h"
#include "protocols/dataset.h"
#include "robot/robot_file.h"
#include "sim/robot_truth.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct FitDatasetsOptions {
  std::string dir;
  std::string out;
  double measured_sigma_factor = 1.4;
  bool hold_intrinsics = false;
  bool no_nonlinear = false;
  bool no_hysteresis = false;
  double hysteresis_sigma_floor_us = -1;  // < 0: calibrate's
  double view_outlier_factor = 5.0;
  std::string covariance_clusters;  // "" (calibrate's), "model", "view", "placement" or "cell:B"
  double robust_sigma_factor = 0;  // 0: calibrate's
  std::string floor_carry;  // "" (calibrate's), none, centres, servo_maps
  double tag_sigma_factor = 0;  // 0: calibrate's
  double pan_zero_factor = 0;  // 0: calibrate's
  std::string fuse_tags;  // "" (calibrate's), on, off
  double fused_floor_scale = -1;  // < 0: calibrate's
  std::string fused_pinhole_floor;   // "" (calibrate's), on, off
  std::string fused_pan_zero_floor;  // "" (calibrate's), on, off
  bool no_figures = false;
  bool quiet = false;
  std::string lens_model = "auto";
};

// The virtual Owl's truth the datasets were recorded with, rebuilt as the robot factory built it
// (the truth file named in the manifest's sim.truth_file, or the built-in one, with the robot
// file's text the manifest kept) and checked against the whole truth the manifest recorded
// (sim.truth_json.robot_truth); nullopt for a real robot.
std::optional<sim::RobotTruth> TruthFromManifest(const nlohmann::json& m, const std::string& path) {
  if (!m.contains("sim") || m["sim"].is_null()) return std::nullopt;
  const nlohmann::json& s = m["sim"];
  if (!s.contains("truth_json") || !s["truth_json"].contains("robot_truth"))
    throw std::runtime_error(path + ": field 'sim.truth_json.robot_truth' is missing (virtual Owl without its truth)");
  const std::string truth_file = s.value("truth_file", "");
  sim::RobotTruth truth = truth_file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(truth_file);
  const nlohmann::json robot = m.value("robot", nlohmann::json::object());
  if (!robot.value("robot_file", "").empty()) {
    const fs::path tmp = fs::temp_directory_path() / ("owlcal_robot_" + std::to_string(::getpid()) + ".yaml");
    std::ofstream(tmp) << robot.value("robot_file_text", "");
    try {
      truth.robot = robot::LoadRobotFile(tmp.string());
    } catch (const std::exception& e) {
      fs::remove(tmp);
      throw std::runtime_error(path + ": field 'robot.robot_file_text': " + e.what());
    }
    fs::remove(tmp);
  }
  if (sim::RobotTruthJson(truth) != s["truth_json"]["robot_truth"])
    throw std::runtime_error(path + ": the truth rebuilt from sim.truth_file ('" + truth_file +
                             "') is not the one recorded in sim.truth_json: the file changed since the recording");
  return truth;
}

int RunFitDatasets(const FitDatasetsOptions& o) {
  if (fs::exists(o.out + "/results.json")) throw UsageError(o.out + " already holds a calibration (results.json); choose a new --out");
  const Progress progress("fit-datasets", o.quiet);
  std::map<std::string, std::string> datasets;
  try {
    datasets = pipeline::FindDatasets(o.dir);
  } catch (const std::runtime_error& e) {
    throw UsageError(e.what());
  }
  // The robot and the truth, from the manifests (every dataset of one calibration was recorded on one robot).
  const std::string first = datasets.begin()->second;
  const std::string first_manifest = first + "/manifest.json";
  const nlohmann::json m0 = protocols::ReadManifest(first);
  pipeline::CalibratePipelineOptions po;
  po.config = pipeline::RobotConfigFromManifest(m0, first_manifest);
  const std::optional<sim::RobotTruth> truth = TruthFromManifest(m0, first_manifest);
  for (const auto& [name, dir] : datasets) {
    const nlohmann::json m = protocols::ReadManifest(dir);
    if (m.value("robot", nlohmann::json::object()).value("config", nlohmann::json()) != m0["robot"]["config"])
      throw std::runtime_error(dir + "/manifest.json: field 'robot.config' differs from " + first_manifest +
                               "'s: the datasets were not recorded on one robot");
    if (m.value("status", "") != "complete")
      progress("dataset " + dir + ": status '" + m.value("status", "") + "' (" + m.value("message", "") + ")");
  }
  if (truth) {
    po.truth = truth->HeadModel();
    po.latency_truth = LatencyTruthOf(*truth);
    po.fps = truth->stream.fps;
    for (int i = 0; i < models::kNumServos; ++i) po.truth_slew_deg_per_s[i] = truth->servos[i].slew_deg_per_s;
    po.truth_latency_s = truth->stream.latency_ms / 1000.0;
  }
  po.head.measured_sigma_factor = o.measured_sigma_factor;
  po.head.fit_intrinsics = !o.hold_intrinsics;
  po.head.fit_nonlinear = !o.no_nonlinear;
  po.head.fit_hysteresis = !o.no_hysteresis;
  if (o.hysteresis_sigma_floor_us >= 0) po.head.hysteresis_sigma_floor_us = o.hysteresis_sigma_floor_us;
  po.head.view_outlier_factor = o.view_outlier_factor;
  if (!o.covariance_clusters.empty()) po.head.covariance_clusters = o.covariance_clusters == "model" ? "" : o.covariance_clusters;
  if (o.robust_sigma_factor > 0) po.head.robust_sigma_factor = o.robust_sigma_factor;
  if (!o.floor_carry.empty()) po.head.intrinsics_floor_carry = o.floor_carry;
  if (o.tag_sigma_factor > 0) po.tag_sigma_factor = o.tag_sigma_factor;
  if (o.pan_zero_factor > 0) po.head.pan_zero_sigma_factor = o.pan_zero_factor;
  if (!o.fuse_tags.empty()) po.fuse_tags = o.fuse_tags == "on";
  if (o.fused_floor_scale >= 0) po.fused_floor_scale = o.fused_floor_scale;
  if (!o.fused_pinhole_floor.empty()) po.fused_pinhole_floor = o.fused_pinhole_floor == "on";
  if (!o.fused_pan_zero_floor.empty()) po.fused_pan_zero_floor = o.fused_pan_zero_floor == "on";
  std::string why;
  if (!pipeline::SetLensModel(o.lens_model, &po, &why)) throw UsageError(why);
  if (!po.Check(&why)) throw UsageError(why);
  po.progress = progress;
  progress("robot: " + po.config.name + (truth ? " (virtual Owl, truth from the manifest)" : ""));
  fitting::CalibrationRun run = pipeline::CalibrateFromDatasets(datasets, po);
  run.settings = {{"command", "owlcal fit-datasets"},
                  {"dir", o.dir},
                  {"out", o.out},
                  {"sigma_factor", o.measured_sigma_factor},
                  {"hold_intrinsics", o.hold_intrinsics},
                  {"no_nonlinear", o.no_nonlinear},
                  {"no_hysteresis", o.no_hysteresis},
                  {"hysteresis_floor", o.hysteresis_sigma_floor_us},
                  {"view_outlier_factor", o.view_outlier_factor},
                  {"covariance_clusters", o.covariance_clusters},
                  {"robust_sigma_factor", o.robust_sigma_factor},
                  {"floor_carry", o.floor_carry},
                  {"tag_sigma_factor", o.tag_sigma_factor},
                  {"pan_zero_factor", o.pan_zero_factor},
                  {"fuse_tags", o.fuse_tags},
                  {"fused_floor_scale", o.fused_floor_scale},
                  {"fused_pinhole_floor", o.fused_pinhole_floor},
                  {"fused_pan_zero_floor", o.fused_pan_zero_floor},
                  {"no_figures", o.no_figures},
                  {"lens_model", o.lens_model},
                  {"owlcal_version", OWLCAL_VERSION}};
  run.result.inputs["command"] = run.settings;
  fs::create_directories(o.out);
  WriteCalibrationFolder(&run, o.out, !o.no_figures, progress);
  return kExitOk;
}

const bool kRegistered = RegisterCommand(
    "fit-datasets",
    "Re-fit a recorded calibration folder (owlcal calibrate's DIR/datasets/) without a robot.\n"
    "Runs calibrate's pipeline on the datasets with the robot and (virtual Owl) the truth their\n"
    "manifests recorded, and writes the same files as calibrate to --out. With the default\n"
    "options it reproduces calibrate's results.json values and sigmas; the options change the fit.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitDatasetsOptions>();
      cmd->add_option("DIR", o->dir, "a folder owlcal calibrate wrote (holds datasets/)")->required()->check(CLI::ExistingDirectory);
      cmd->add_option("--out", o->out, "report folder to create")->required();
      cmd->add_option("--sigma-factor",
                      o->measured_sigma_factor,
                      "head fit: factor on the measured corner sigma (calibrate: 1.4)")
          ->check(CLI::Range(0.1, 100.0));
      cmd->add_flag("--hold-intrinsics", o->hold_intrinsics, "head fit: hold the intrinsics at the stereo fit's");
      cmd->add_flag("--no-nonlinear", o->no_nonlinear, "head fit: servo maps linear (quad and cubic held at 0)");
      cmd->add_flag("--no-hysteresis", o->no_hysteresis, "head fit: no backlash (hysteresis held at 0)");
      cmd->add_option("--hysteresis-floor", o->hysteresis_sigma_floor_us, "head fit: floor of the hysteresis sigma [us]")
          ->check(CLI::Range(0.0, 100.0));
      cmd->add_option("--view-outlier-factor", o->view_outlier_factor,
                      "head fit: drop views whose RMS exceeds this times the median view's (0 = off)")
          ->check(CLI::Range(0.0, 1e6));
      cmd->add_option("--covariance-clusters",
                      o->covariance_clusters,
                      "head fit: sigma from the residuals, clustered by view, placement or cell:B (the views of a placement "
                      "whose commands share a B us cell; fitting/observability.h ClusterRobustCovariance), or model "
                      "(the model covariance alone); default: calibrate's")
          ->check([](const std::string& v) {
            if (v == "model" || v == "view" || v == "placement") return std::string();
            if (fitting::HeadFitOptions::CellOfClusters(v) >= 1) return std::string();
            return std::string("must be model, view, placement or cell:B (B >= 1 us)");
          });
      cmd->add_option("--robust-sigma-factor",
                      o->robust_sigma_factor,
                      "head fit: factor on the clustered sigma, for the bias every view shares")
          ->check(CLI::Range(1.0, 10.0));
      cmd->add_option("--floor-carry",
                      o->floor_carry,
                      "head fit: where the intrinsics floor (the stereo fit's covariance) is carried beyond the "
                      "intrinsics: none, centres (servo centres) or servo_maps (every servo map coordinate)")
          ->check(CLI::IsMember({"none", "centres", "servo_maps"}));
      cmd->add_option("--pan-zero-factor",
                      o->pan_zero_factor,
                      "head fit: factor on the sigma of the pan zero (both pan maps' common angle; "
                      "HeadFitOptions::pan_zero_sigma_factor; default: calibrate's)")
          ->check(CLI::Range(1.0, 99.0));
      cmd->add_option("--tag-sigma-factor",
                      o->tag_sigma_factor,
                      "head fit fused with the servo sweep's tag sheets: factor on the tag corners' measured sigma "
                      "(default: calibrate's)")
          ->check(CLI::Range(1.0, 99.0));
      cmd->add_option("--fuse-tags",
                      o->fuse_tags,
                      "on: the result's head is the fit fusing the chessboard with the tag sheets; off: the "
                      "chessboard's alone (default: calibrate's)")
          ->check(CLI::IsMember({"on", "off"}));
      cmd->add_option("--fused-floor-scale",
                      o->fused_floor_scale,
                      "the fit fusing the tag sheets: its intrinsics covariance floor is the stereo fit's times this "
                      "squared (1: the chessboard fit's; 0: none; default: calibrate's)")
          ->check(CLI::Range(0.0, 10.0));
      cmd->add_option(
             "--fused-pinhole-floor",
             o->fused_pinhole_floor,
             "the fit fusing the tag sheets: on: its focal scale (mean log focal length) and principal points no "
             "more certain than the stereo fit's (default: calibrate's)")
          ->check(CLI::IsMember({"on", "off"}));
      cmd->add_option("--fused-pan-zero-floor",
                      o->fused_pan_zero_floor,
                      "the fit fusing the tag sheets: on: its pan zero (both pans' common angle) no more certain "
                      "than the chessboard fit's (default: calibrate's)")
          ->check(CLI::IsMember({"on", "off"}));
      AddCalibrationOutputOptions(cmd, &o->no_figures, &o->quiet, &o->lens_model);
      return [o] { return RunFitDatasets(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
