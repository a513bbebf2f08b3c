// owlcal check-calibration DIR --calib CAL --target T.yaml --out OUT: does a stereo calibration
// still hold on new images of the board? (as ROS's cameracheck, plus a verdict and what moved;
// evaluation/calibration_check.h).
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

#include <nlohmann/json.hpp>

#include "apps/command_registry.h"
#include "calib/image_pairs.h"
#include "calib/target_file.h"
#include "evaluation/calibration_check.h"
#include "fitting/format.h"
#include "reports/calibration_check_tables.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;
using fitting::FixedOrDash;

struct CheckCalibrationOptions {
  std::string dir, calib, target, out;
  bool side_by_side = false, mirror = false, swap = false;
  evaluation::CalibrationCheckOptions check;
};

nlohmann::json ParamsJson(const std::vector<evaluation::CheckedParameter>& ps) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& p : ps)
    a.push_back({{"name", p.name},
                 {"unit", p.unit},
                 {"calibrated", p.calibrated},
                 {"refit", p.refit},
                 {"sigma_calibration", p.sigma_calibration},
                 {"sigma_refit", p.sigma_refit},
                 {"z", p.z},
                 {"moved", p.moved}});
  return a;
}

int RunCheckCalibration(const CheckCalibrationOptions& a) {
  std::string why;
  if (!a.check.Check(&why)) throw UsageError(why);
  const calib::TargetFile tf = calib::LoadTargetFileWithUnit(a.target);
  if (tf.unit != "m")
    throw UsageError(a.target + ": sizes are in '" + tf.unit + "'; the calibration's T is in metres, so the board " +
                     "must be given in metres too");
  const fitting::StereoRig rig = fitting::LoadStereoRig(a.calib);
  calib::ImagePairOptions po;
  po.side_by_side = a.side_by_side;
  po.mirror = a.mirror;
  po.swap = a.swap;
  const calib::ImagePairList list = calib::ListImagePairs(a.dir, po);
  const calib::DetectedImageSet set = calib::DetectImagePairs(list, po, tf.target, {});
  if (set.width != rig.cameras[0].width || set.height != rig.cameras[0].height)
    throw std::runtime_error(a.dir + ": images are " + std::to_string(set.width) + "x" + std::to_string(set.height) +
                             ", the calibration is for " + std::to_string(rig.cameras[0].width) + "x" +
                             std::to_string(rig.cameras[0].height));
  int not_found = 0;
  for (const auto& p : set.pairs)
    for (int e = 0; e < 2; ++e)
      if (!p.found[e]) {
        ++not_found;
        std::cout << p.key << (e ? " right" : " left") << ": board not found (" << p.message[e] << ")\n";
      }
  const evaluation::CalibrationCheck c = evaluation::CheckCalibration(rig, set.observations, a.check);
  fs::create_directories(a.out);
  const std::string md = reports::CalibrationCheckMarkdown(c, rig.source);
  reports::WriteTextFile((fs::path(a.out) / "check.md").string(),
                         md + (not_found ? "\nThe board was not found in " + std::to_string(not_found) +
                                               " eye image(s); they were not used.\n"
                                         : ""));
  nlohmann::json j = {{"calibration", rig.source},
                      {"images", a.dir},
                      {"ok", c.ok},
                      {"message", c.message},
                      {"verdict", c.verdict},
                      {"reasons", c.reasons},
                      {"moved", c.moved},
                      {"pairs", c.num_pairs},
                      {"eye_images_without_board", not_found},
                      {"fixed",
                       {{"rms_px", {c.rms_px[0], c.rms_px[1]}},
                        {"sigma_rms_px", {c.sigma_rms_px[0], c.sigma_rms_px[1]}},
                        {"rms_joint_px", c.rms_joint_px},
                        {"sigma_rms_joint_px", c.sigma_rms_joint_px},
                        {"mono_rms_px", {c.mono_rms_px[0], c.mono_rms_px[1]}},
                        {"epipolar_mean_dy_px", c.epipolar_mean_dy_px},
                        {"sigma_epipolar_mean_dy_px", c.sigma_epipolar_mean_dy_px},
                        {"epipolar_rms_dy_px", c.epipolar_rms_dy_px},
                        {"epipolar_max_dy_px", c.epipolar_max_dy_px}}},
                      {"refit",
                       {{"extrinsics_rms_px", c.refit_extrinsics_rms_px},
                        {"all_rms_px", c.refit_all_rms_px},
                        {"all_epipolar_rms_px", c.refit_all_epipolar_rms_dy_px},
                        {"corner_sigma_px", c.corner_sigma_px},
                        {"extrinsics", ParamsJson(c.extrinsics)},
                        {"intrinsics_and_extrinsics", ParamsJson(c.all)}}},
                      {"range_at_1m_m", c.range_at_1m_m}};
  reports::WriteTextFile((fs::path(a.out) / "check.json").string(), j.dump(2) + "\n");
  std::cout << md << "\nwrote " << a.out << ": check.md check.json\n";
  if (!c.ok) return kExitFailed;
  // Exit 0 when the calibration still holds, 3 when it should be redone (scripts can test it).
  return c.verdict == "still valid" ? kExitOk : 3;
}

const bool kCheckCalibrationRegistered = RegisterCommand(
    "check-calibration",
    "Check a stereo calibration on new images of the board (as ROS's cameracheck): with the calibration held\n"
    "fixed, reprojection RMS per eye and joint and the rectified epipolar error, each with sigma; refits of\n"
    "the extrinsics and of fx fy cx cy + extrinsics say which parameters moved (z against both sigmas); verdict\n"
    "'still valid' (exit 0) or 'recalibrate' (exit 3). Consumes a folder of left*/right* pairs (or --side-by-side\n"
    "frames), a calibration (results.json, calibration.yaml, intrinsics.xml) and the target file; writes\n"
    "OUT/check.md and OUT/check.json.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CheckCalibrationOptions>();
      cmd->add_option("dir", o->dir, "folder of new image pairs")->required()->check(CLI::ExistingDirectory);
      cmd->add_option("--calib", o->calib, "calibration file or folder")->required();
      cmd->add_option("--target", o->target, "target file (data/targets/*.yaml)")->required()->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_flag("--side-by-side", o->side_by_side, "images are 1280x480 stream frames");
      cmd->add_flag("--mirror", o->mirror, "images are mirrored (see calibrate-images)");
      cmd->add_flag("--swap", o->swap, "exchange the eyes");
      cmd->add_option("--moved-sigma", o->check.moved_sigma, "a parameter moved when |z| exceeds this")
          ->capture_default_str();
      cmd->add_option("--max-rms-ratio", o->check.max_rms_ratio, "fixed / refit RMS allowed")->capture_default_str();
      cmd->add_option("--max-epipolar-px", o->check.max_epipolar_rms_px, "rectified epipolar RMS allowed [px]")
          ->capture_default_str();
      cmd->add_option("--max-range-error-pct", o->check.max_range_error_pct, "range error at 1 m allowed [%]")
          ->capture_default_str();
      return [o] { return RunCheckCalibration(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
