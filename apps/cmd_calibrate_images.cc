// owlcal calibrate-images DIR --target FILE --out OUT [--mirror] [--side-by-side] [--swap]:
// stereo calibration from a folder of image pairs a student already has.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "calib/image_pairs.h"
#include "calib/observation_io.h"
#include "calib/target_file.h"
#include "evaluation/fit_points.h"
#include "evaluation/range_images_calib.h"
#include "evaluation/reference_comparison.h"
#include "fitting/calibration_folder.h"
#include "fitting/fix_list.h"
#include "owlcal_version.h"
#include "reports/exports.h"
#include "reports/image_set_tables.h"
#include "reports/report.h"
#include "reports/report_data.h"
#include "reports/table.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct CalibrateImagesOptions {
  std::string dir, target, out;
  bool mirror = false, side_by_side = false, swap = false;
  std::string model = "auto";
  std::string board_warp = "auto";
  bool no_report = false;
  std::string rig = "auto";
  double ipd_mm = 65;
  std::string reference;  // the course's intrinsics.xml/extrinsics.xml folder, or one calibration file
  std::string fix;        // parameters held (fitting/fix_list.h), comma-separated
};

// The reference calibration: a folder holding intrinsics.xml and extrinsics.xml (the course's
// stereo_calib output), or one OpenCV calibration file with every field.
fitting::OpenCvStereoCalibration ReadReference(const std::string& path) {
  if (fs::is_directory(path)) {
    const fs::path in = fs::path(path) / "intrinsics.xml", ex = fs::path(path) / "extrinsics.xml";
    if (!fs::exists(in) || !fs::exists(ex))
      throw UsageError("--reference " + path +
                       ": the folder needs intrinsics.xml and extrinsics.xml (the course's "
                       "stereo_calib output)");
    fitting::CheckOneRun(path);
    return fitting::ReadOpenCvSplitFiles(in.string(), ex.string());
  }
  // A file of a calibration folder (calibration.yaml ...) only when the folder holds one run.
  fitting::CheckOneRunOfPath(path);
  return fitting::ReadOpenCvCalibration(path);
}

// The rig the sanity checks expect (into vo): the Owl (lens family, IPD) for a metric target,
// unless the fit is plainly not an Owl (then a generic pair, said once: evaluation/set_verdict.h
// recognise_rig); a generic side-by-side pair otherwise (OpenCV's sample in squares); or as asked.
void RigFor(const std::string& rig, const std::string& unit, double ipd_mm, evaluation::SetVerdictOptions* vo) {
  evaluation::RigExpectation e;
  const bool metric = unit == "m" || unit == "mm";
  if (rig == "owl" || (rig == "auto" && metric)) {
    e = evaluation::RigExpectation::Owl();
    e.ipd_m = ipd_mm / 1000;
  } else if (rig == "generic" || rig == "auto") {
    e = evaluation::RigExpectation::Generic();
  } else {
    throw UsageError("--rig = '" + rig + "': use auto, owl or generic");
  }
  std::string why;
  if (!e.Check(&why)) throw UsageError(why);
  vo->rig = e;
  vo->recognise_rig = rig == "auto" && metric;
}

// One line per eye whose board was missed somewhere: how many images, and what was tried.
void WarnAboutMissedBoards(const calib::DetectedImageSet& set) {
  const char* eye[2] = {"left", "right"};
  for (int e = 0; e < 2; ++e) {
    int found = 0;
    const calib::PairDetection* missed = nullptr;
    for (const auto& p : set.pairs) {
      found += p.found[e];
      if (!p.found[e] && !missed) missed = &p;
    }
    if (missed)
      std::cerr << "warning: " << eye[e] << " eye: board found in " << found << " of " << set.pairs.size()
                << " images; pair " << missed->key << ": " << missed->message[e] << "\n";
  }
}

int RunCalibrateImages(const CalibrateImagesOptions& a) {
  const calib::TargetFile target = calib::LoadTargetFileWithUnit(a.target);
  if (!a.reference.empty() && (a.mirror || a.swap))
    throw UsageError(
        "--reference: the reference was computed on the images as they are; --mirror/--swap change "
        "them, so the two cannot be compared parameter by parameter");
  const std::optional<fitting::OpenCvStereoCalibration> reference =
      a.reference.empty() ? std::nullopt : std::optional(ReadReference(a.reference));
  fitting::StereoFitOptions fo;
  fo.length_unit = target.unit;
  fitting::LensModelChoiceOptions lens;  // auto: chosen by cross-validation over the pairs
  if (a.model == "opencv8")
    fo.intrinsics.model = models::DistortionModel::kOpenCv8;
  else if (a.model != "opencv5" && a.model != "auto")
    throw UsageError("--model = '" + a.model + "': use auto, opencv5 or opencv8");
  if (a.model != "auto") lens.enabled = false;
  fitting::LensModelChoiceOptions warp;  // auto: flat or bowed board by cross-validation
  if (a.board_warp == "bowed")
    fo.fit_board_warp = true;
  else if (a.board_warp != "flat" && a.board_warp != "auto")
    throw UsageError("--board-warp = '" + a.board_warp + "': use auto, flat or bowed");
  if (a.board_warp != "auto") warp.enabled = false;
  std::string why;
  if (!fitting::ApplyFixList(a.fix, &fo.intrinsics, &why)) throw UsageError(why);
  for (int k : fo.intrinsics.fix_radial)
    if (k > 3 && a.model == "opencv5")
      throw UsageError("--fix k" + std::to_string(k) + ": the opencv5 model has no k" + std::to_string(k) +
                       " (it is one of opencv8's; use --model opencv8 or auto)");
  if (!fo.intrinsics.Check(&why)) throw UsageError(why);
  evaluation::SetVerdictOptions vo;
  RigFor(a.rig, target.unit, a.ipd_mm, &vo);

  // The folder holds this run alone: what an earlier run left goes before any work
  // (apps/output_folder.h), so an unusable set never leaves an earlier set's calibration.yaml and
  // exports behind, and a folder that is not owlcal's is refused before the detection and the fit.
  const std::string run_id = StartRun(a.out, [](const std::string& m) { std::cerr << m << "\n"; });
  calib::ImagePairOptions po;
  po.mirror = a.mirror;
  po.side_by_side = a.side_by_side;
  po.swap = a.swap;
  const calib::ImagePairList list = calib::ListImagePairs(a.dir, po);
  for (const auto& u : list.unpaired) std::cerr << "warning: " << u << " has no partner; ignored\n";
  // The detection of every command (calib/detector.h: classic then sb, both orientations).
  const calib::DetectedImageSet set = calib::DetectImagePairs(list, po, target.target, calib::DetectorOptions());
  WarnAboutMissedBoards(set);
  fo.width = set.width;
  fo.height = set.height;
  if (!fo.Check(&why)) throw UsageError(why);
  evaluation::ImageSetCalibration c = evaluation::CalibrateImageSet(set.observations, fo, vo, lens, warp);
  StampRun(run_id, &c.result);
  c.result.inputs["images"] = a.dir;
  c.result.inputs["target"] = a.target;
  c.result.inputs["mirror"] = a.mirror;
  c.result.inputs["side_by_side"] = a.side_by_side;
  c.result.inputs["swap"] = a.swap;
  c.result.inputs["rig"] = a.rig;
  c.result.inputs["fix"] = fitting::FixListOf(fo.intrinsics);
  if (!c.set_verdict.rig_note.empty()) std::cerr << c.set_verdict.rig_note << "\n";
  nlohmann::json det_j = nlohmann::json::array();
  std::vector<std::string> keys;
  for (const auto& p : set.pairs) {
    keys.push_back(p.key);
    det_j.push_back({{"pair", p.key},
                     {"left_found", p.found[0]},
                     {"right_found", p.found[1]},
                     {"left_message", p.message[0]},
                     {"right_message", p.message[1]}});
  }
  c.result.diagnostics["detections"] = det_j;
  const std::vector<calib::View> views = calib::GroupIntoViews(set.observations);
  std::string reference_md;
  if (reference) {
    std::vector<calib::View> eye_views[2];
    for (const auto& v : views) eye_views[v.eye == 0 ? 0 : 1].push_back(v);
    evaluation::ReferenceComparisonOptions ro;
    ro.reference_name = "reference " + a.reference;
    // The bow's part: the same fit with a flat board (the chosen lens model kept).
    std::optional<fitting::StereoFit> flat;
    if (c.fit.board_warp_fitted) {
      fitting::StereoFitOptions fl = fo;
      fl.intrinsics.model = c.fit.cameras[0].model;
      fl.fit_board_warp = false;
      flat = fitting::FitStereo(eye_views[0], eye_views[1], fl);
    }
    const evaluation::ReferenceComparison cmp =
        evaluation::CompareWithReference(eye_views[0], eye_views[1], c.fit, flat ? &*flat : nullptr, *reference, ro);
    c.result.diagnostics["reference_comparison"] = evaluation::ReferenceComparisonToJson(cmp);
    c.result.inputs["reference"] = a.reference;
    reference_md = evaluation::ReferenceComparisonMarkdown(cmp);
    if (!cmp.ok) std::cerr << "warning: not compared with " << a.reference << ": " << cmp.message << "\n";
  }

  const fs::path out(a.out);
  calib::WriteObservationsCsv((out / "observations.csv").string(), set.observations);
  const std::string md = reports::ImageSetReportMarkdown(c, keys) + (reference_md.empty() ? "" : "\n" + reference_md);
  reports::WriteTextFile((out / "calibration.md").string(), md);
  std::vector<std::string> written = {"observations.csv", "results.json", "evaluation.json", "calibration.md"};
  // The report's data: the corners' residuals, views and board poses; no robot was involved
  // (only the image size of the configuration is meaningful).
  reports::ReportData rd;
  rd.result = c.result;
  rd.config.name = "none (calibration from images)";
  rd.config.image_width = set.width;
  rd.config.image_height = set.height;
  rd.settings = {{"command", "owlcal calibrate-images"},
                 {"images", a.dir},
                 {"target", a.target},
                 {"mirror", a.mirror},
                 {"side_by_side", a.side_by_side},
                 {"swap", a.swap},
                 {"model", a.model},
                 {"board_warp", a.board_warp},
                 {"fix", a.fix},
                 {"owlcal_version", OWLCAL_VERSION},
                 {"robot", "none"}};
  auto name_of = [&](int frame, int eye) {
    const std::string key =
        frame >= 0 && frame < int(list.pairs.size()) ? list.pairs[frame].key : std::to_string(frame);
    const std::string& path = frame >= 0 && frame < int(list.pairs.size())
                                  ? (eye == 0 ? list.pairs[frame].left_path : list.pairs[frame].right_path)
                                  : key;
    return "pair " + key + " (" + fs::path(path).filename().string() + ")";
  };
  evaluation::AddFitPoints(c.fit, views, name_of, &rd);
  reports::WriteReportData(rd, a.out);
  if (c.set_verdict.status != "unusable") {
    const reports::ExportSet ex = reports::WriteCalibrationFiles(rd, a.out);
    for (const auto& p : ex.written) written.push_back(fs::relative(p, out).string());
    for (const auto& s : ex.skipped) std::cerr << "export skipped: " << s << "\n";
  } else {
    // Numbers owlcal cannot stand behind are not handed to other programs.
    std::cerr << "calibration.yaml and exports not written: the set is unusable ("
              << (c.set_verdict.reasons.empty() ? std::string("see calibration.md") : c.set_verdict.reasons.front())
              << ")\n";
  }
  if (!a.no_report) {
    reports::ReportOptions ro;
    ro.title = "owlcal calibration from images: " + a.dir;
    const auto rep = reports::WriteReport(rd, a.out, ro);
    for (const auto& w : rep.warnings) std::cerr << "report: " << w << "\n";
    written.insert(written.end(), {"figures/", "tables/", "report/index.html"});
  }
  std::cout << md << "\nwrote " << a.out << ":";
  for (const auto& w : written) std::cout << " " << w;
  std::cout << "\n";
  std::cout << "verdict: " << c.set_verdict.status << "\n";
  if (!c.fit.ok || c.set_verdict.status == "unusable") return kExitFailed;
  return kExitOk;
}

const bool kCalibrateImagesRegistered = RegisterCommand(
    "calibrate-images",
    "Stereo calibration from a folder of image pairs (left*/right* files, or 1280x480 side-by-side frames\n"
    "with --side-by-side): detect the target, fit both cameras and R, T with sigma, write results.json,\n"
    "calibration.yaml (OpenCV, metres), the course's intrinsics.xml/extrinsics.xml (mm), exports/ (ROS,\n"
    "Kalibr, mrcal), calibration.md (verdict, per-view residuals, coverage) and the report\n"
    "(report/index.html, figures/, tables/). The set gets a verdict (good, poor, unusable) from what it leaves\n"
    "uncertain: projection uncertainty, sigma of f and c, two halves calibrated alone, physical sanity (a mirrored or\n"
    "swapped set is named with the flag that fixes it); reasons and advice on which views to add. An unusable set's\n"
    "numbers are refused (exit 1, no exports).",
    [](CLI::App* cmd) {
      auto o = std::make_shared<CalibrateImagesOptions>();
      cmd->add_option("dir", o->dir, "folder of image pairs")->required()->check(CLI::ExistingDirectory);
      cmd->add_option("--target", o->target, "target file (e.g. data/targets/owl-kit-chessboard.yaml)")
          ->required()
          ->check(CLI::ExistingFile);
      cmd->add_option("--out", o->out, "output folder")->required();
      cmd->add_flag("--mirror",
                    o->mirror,
                    "images are mirrored: flip each file (separate files), or flip the whole frame before "
                    "splitting (side-by-side, the owl.h convention for raw stream frames)");
      cmd->add_flag("--side-by-side", o->side_by_side, "each file is one side-by-side stereo frame");
      cmd->add_flag("--swap", o->swap, "exchange left and right eyes");
      cmd->add_option("--model",
                      o->model,
                      "distortion model: auto (opencv5 or the rational opencv8, chosen by 5-fold cross-validation "
                      "over the pairs: the smaller held-out RMS), opencv5 or opencv8")
          ->capture_default_str();
      cmd->add_option("--board-warp",
                      o->board_warp,
                      "the board's bow (mrcal's two-parameter deflection): auto (flat or bowed, chosen by 5-fold "
                      "cross-validation over the pairs), flat or bowed")
          ->capture_default_str();
      cmd->add_option("--fix",
                      o->fix,
                      "parameters held in both eyes' fits, comma-separated, as OpenCV's CALIB_FIX_* flags: k1 ... k6 "
                      "(held at 0), principal_point (at the image centre), aspect_ratio (fy = fx) and tangential "
                      "(p1 = p2 = 0); held parameters are marked held (sigma 0) in results.json, calibration.md and "
                      "the exports");
      cmd->add_flag("--no-report", o->no_report, "skip the HTML report");
      cmd->add_option(
             "--rig",
             o->rig,
             "what the sanity checks expect: owl (3.6 mm lens on the OV5647, IPD), generic (any side-by-side "
             "pair), auto (owl for a metric target, unless the fit is plainly not an Owl: baseline outside the IPD "
             "tolerance and f outside the lens family; then generic, said once)")
          ->capture_default_str();
      cmd->add_option("--ipd-mm", o->ipd_mm, "the robot's IPD for the baseline check [mm]")->capture_default_str();
      cmd->add_option("--reference",
                      o->reference,
                      "a calibration of the same images made elsewhere (a folder with the course's intrinsics.xml and "
                      "extrinsics.xml, or one OpenCV file): owlcal's result is compared parameter by parameter and the "
                      "difference split into corner detection, lens-model choice and estimator (calibration.md, "
                      "results.json diagnostics.reference_comparison, the report)")
          ->check(CLI::ExistingPath);
      return [o] { return RunCalibrateImages(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
