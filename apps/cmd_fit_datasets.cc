// owlcal fit-datasets DIR --out NEW: pipeline::FitDatasets (pipeline/calibrate.h) on a folder
// `owlcal calibrate` wrote, with no robot, then the same calibration folder as calibrate. Every
// option starts at calibrate's value (pipeline::DefaultFitOptions), so with none given every
// results.json value and sigma is the one calibrate wrote; the options change the fit.
#include <filesystem>
#include <memory>
#include <string>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "owlcal_version.h"
#include "pipeline/calibrate.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

// The command's options: the pipeline's (calibrate's defaults, changed in place by the flags) and
// the output's.
struct FitDatasetsCommand {
  std::string dir;
  std::string out;
  pipeline::FitDatasetsOptions fit;
  bool hold_intrinsics = false;
  bool no_nonlinear = false;
  bool no_hysteresis = false;
  bool no_figures = false;
  bool quiet = false;
  std::string lens_model = "auto";
  std::string covariance_clusters;  // --covariance-clusters, parsed into fit.fit.head
  std::string floor_carry;          // --floor-carry, parsed into fit.fit.head
};

int RunFitDatasets(FitDatasetsCommand o) {
  if (fs::exists(o.out + "/results.json"))
    throw UsageError(o.out + " already holds a calibration (results.json); choose a new --out");
  const Progress progress("fit-datasets", o.quiet);
  pipeline::CalibratePipelineOptions& po = o.fit.fit;
  fitting::HeadFitOptions& head = po.head;
  head.fit_intrinsics = !o.hold_intrinsics;
  head.fit_nonlinear = !o.no_nonlinear;
  head.fit_hysteresis = !o.no_hysteresis;
  // The CLI checks both spellings; an unparsable one cannot reach here.
  head.covariance_clusters = *fitting::CovarianceClusters::Parse(o.covariance_clusters);
  head.intrinsics_floor_carry = *fitting::ParseFloorCarry(o.floor_carry);
  std::string why;
  if (!pipeline::SetLensModel(o.lens_model, &po, &why) || !po.Check(&why)) throw UsageError(why);
  o.fit.progress = progress;
  po.warning = PrintWarning;
  evaluation::CalibrationRun run;
  try {
    run = pipeline::FitDatasets(o.dir, o.fit);
  } catch (const pipeline::NoDatasetsError& e) {
    throw UsageError(e.what());
  }
  run.settings = {{"command", "owlcal fit-datasets"},
                  {"dir", o.dir},
                  {"out", o.out},
                  {"sigma_factor", head.measured_sigma_factor},
                  {"hold_intrinsics", o.hold_intrinsics},
                  {"no_nonlinear", o.no_nonlinear},
                  {"no_hysteresis", o.no_hysteresis},
                  {"hysteresis_floor", head.hysteresis_sigma_floor_us},
                  {"view_outlier_factor", head.view_outlier_factor},
                  {"covariance_clusters", o.covariance_clusters},
                  {"robust_sigma_factor", head.robust_sigma_factor},
                  {"floor_carry", o.floor_carry},
                  {"tag_sigma_factor", po.tag_sigma_factor},
                  {"pan_zero_factor", head.pan_zero_sigma_factor},
                  {"fuse_tags", po.fuse_tags},
                  {"fused_floor_scale", po.fused_floor_scale},
                  {"fused_pinhole_floor", po.fused_pinhole_floor},
                  {"fused_pan_zero_floor", po.fused_pan_zero_floor},
                  {"no_figures", o.no_figures},
                  {"lens_model", o.lens_model},
                  {"owlcal_version", OWLCAL_VERSION}};
  run.result.inputs["command"] = run.settings;
  const std::string run_id = StartRun(o.out, progress);
  WriteCalibrationFolder(&run, run_id, o.out, !o.no_figures, progress);
  return kExitOk;
}

const bool kFitDatasetsRegistered = RegisterCommand(
    "fit-datasets",
    "Re-fit a recorded calibration folder (owlcal calibrate's DIR/datasets/) without a robot.\n"
    "Runs calibrate's pipeline on the datasets with the robot and (virtual Owl) the truth their\n"
    "manifests recorded, and writes the same files as calibrate to --out. With the default\n"
    "options it reproduces calibrate's results.json values and sigmas; the options change the fit.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitDatasetsCommand>();
      pipeline::CalibratePipelineOptions& po = o->fit.fit;
      const fitting::CovarianceClusters& clusters = po.head.covariance_clusters;
      o->covariance_clusters = clusters.kind == fitting::CovarianceClusters::Kind::kModel ? "model" : clusters.Spec();
      o->floor_carry = fitting::FloorCarryName(po.head.intrinsics_floor_carry);
      cmd->add_option("DIR", o->dir, "a folder owlcal calibrate wrote (holds datasets/)")
          ->required()
          ->check(CLI::ExistingDirectory);
      cmd->add_option("--out", o->out, "report folder to create")->required();
      cmd->add_option("--sigma-factor", po.head.measured_sigma_factor, "head fit: factor on the measured corner sigma")
          ->capture_default_str()
          ->check(CLI::Range(0.1, 100.0));
      cmd->add_flag("--hold-intrinsics", o->hold_intrinsics, "head fit: hold the intrinsics at the stereo fit's");
      cmd->add_flag("--no-nonlinear", o->no_nonlinear, "head fit: servo maps linear (quad and cubic held at 0)");
      cmd->add_flag("--no-hysteresis", o->no_hysteresis, "head fit: no backlash (hysteresis held at 0)");
      cmd->add_option(
             "--hysteresis-floor", po.head.hysteresis_sigma_floor_us, "head fit: floor of the hysteresis sigma [us]")
          ->capture_default_str()
          ->check(CLI::Range(0.0, 100.0));
      cmd->add_option("--view-outlier-factor",
                      po.head.view_outlier_factor,
                      "head fit: drop views whose RMS exceeds this times the median view's (0 = off)")
          ->check(CLI::Range(0.0, 1e6));
      cmd->add_option(
             "--covariance-clusters",
             o->covariance_clusters,
             "head fit: sigma from the residuals, clustered by view, placement or cell:B (the views of a placement "
             "whose commands share a B us cell; fitting/observability.h ClusterRobustCovariance), or model "
             "(the model covariance alone)")
          ->capture_default_str()
          ->check([](const std::string& v) {
            if (fitting::CovarianceClusters::Parse(v)) return std::string();
            return std::string("must be model, view, placement or cell:B (B >= 1 us)");
          });
      cmd->add_option("--robust-sigma-factor",
                      po.head.robust_sigma_factor,
                      "head fit: factor on the clustered sigma, for the bias every view shares")
          ->capture_default_str()
          ->check(CLI::Range(1.0, 10.0));
      cmd->add_option("--floor-carry",
                      o->floor_carry,
                      "head fit: where the intrinsics floor (the stereo fit's covariance) is carried beyond the "
                      "intrinsics: none, centres (servo centres) or servo_maps (every servo map coordinate)")
          ->capture_default_str()
          ->check(CLI::IsMember({"none", "centres", "servo_maps"}));
      cmd->add_option("--pan-zero-factor",
                      po.head.pan_zero_sigma_factor,
                      "head fit: factor on the sigma of the pan zero (both pan maps' common angle; "
                      "HeadFitOptions::pan_zero_sigma_factor)")
          ->capture_default_str()
          ->check(CLI::Range(1.0, 99.0));
      cmd->add_option("--tag-sigma-factor",
                      po.tag_sigma_factor,
                      "head fit fused with the servo sweep's tag sheets: factor on the tag corners' measured sigma")
          ->capture_default_str()
          ->check(CLI::Range(1.0, 99.0));
      cmd->add_option("--fuse-tags",
                      po.fuse_tags,
                      "on (or true): the result's head is the fit fusing the chessboard with the tag sheets; off: the "
                      "chessboard's alone")
          ->capture_default_str();
      cmd->add_option("--fused-floor-scale",
                      po.fused_floor_scale,
                      "the fit fusing the tag sheets: its intrinsics covariance floor is the stereo fit's times this "
                      "squared (1: the chessboard fit's; 0: none)")
          ->capture_default_str()
          ->check(CLI::Range(0.0, 10.0));
      cmd->add_option(
             "--fused-pinhole-floor",
             po.fused_pinhole_floor,
             "the fit fusing the tag sheets: on: its focal scale (mean log focal length) and principal points no "
             "more certain than the stereo fit's")
          ->capture_default_str();
      cmd->add_option("--fused-pan-zero-floor",
                      po.fused_pan_zero_floor,
                      "the fit fusing the tag sheets: on: its pan zero (both pans' common angle) no more certain "
                      "than the chessboard fit's")
          ->capture_default_str();
      AddCalibrationOutputOptions(cmd, &o->no_figures, &o->quiet, &o->lens_model);
      return [o] { return RunFitDatasets(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
