// owlcal fit: observation CSV -> intrinsics per eye (+ stereo when both eyes are present),
// results.json (fitting/result.h) and calibration.yaml (OpenCV FileStorage, stereo sample fields).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "apps/command_registry.h"
#include "calib/observation_io.h"
#include "calib/target_file.h"
#include "evaluation/stereo_sanity.h"
#include "fitting/intrinsics_fit.h"
#include "fitting/opencv_calib_file.h"
#include "fitting/result.h"
#include "fitting/stereo_fit.h"
#include "owlcal_version.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;

struct FitCmdOptions {
  std::string obs_path;
  std::string out_dir;
  std::string model = "opencv5";
  std::string loss = "none";
  std::string unit;
  std::string target_path;
  int width = 640, height = 480;
  double sigma_px = 0;
  double outlier_sigma = 6;
  bool fix_k3 = false, fix_aspect = false, fix_tangential = false, fix_pp = false;
  std::string rig = "auto";
};

std::string Fnv1a64(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  uint64_t h = 1469598103934665603ull;
  char c;
  while (f.get(c)) {
    h ^= uint8_t(c);
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

void PrintParameters(const fitting::CalibrationResult& r) {
  for (const fitting::Parameter& p : r.parameters) {
    char line[256];
    if (p.determined) {
      std::snprintf(
          line, sizeof(line), "  %-22s %14.6g +- %-10.3g %s", p.name.c_str(), p.value, p.sigma, p.unit.c_str());
    } else {
      std::snprintf(line, sizeof(line), "  %-22s %14s    NOT DETERMINED: %s", p.name.c_str(), "-", p.note.c_str());
    }
    std::cout << line << "\n";
  }
}

int RunFit(const FitCmdOptions& o) {
  fitting::StereoFitOptions sopt;
  sopt.width = o.width;
  sopt.height = o.height;
  fitting::IntrinsicsFitOptions& iopt = sopt.intrinsics;
  if (o.model == "opencv8") {
    iopt.model = models::DistortionModel::kOpenCv8;
  } else if (o.model != "opencv5") {
    throw UsageError("--model must be opencv5 or opencv8, got '" + o.model + "'");
  }
  if (o.loss == "huber") {
    iopt.loss = fitting::RobustLoss::kHuber;
  } else if (o.loss == "cauchy") {
    iopt.loss = fitting::RobustLoss::kCauchy;
  } else if (o.loss != "none") {
    throw UsageError("--loss must be none, huber or cauchy, got '" + o.loss + "'");
  }
  iopt.corner_sigma_px = o.sigma_px;
  iopt.outlier_threshold_sigma = o.outlier_sigma;
  iopt.fix_k3 = o.fix_k3;
  iopt.fix_aspect_ratio = o.fix_aspect;
  iopt.fix_tangential = o.fix_tangential;
  iopt.fix_principal_point = o.fix_pp;
  sopt.length_unit = "m";
  if (!o.target_path.empty()) sopt.length_unit = calib::LoadTargetFileWithUnit(o.target_path).unit;
  if (!o.unit.empty()) sopt.length_unit = o.unit;
  std::string why;
  if (!sopt.Check(&why)) throw UsageError(why);

  const std::vector<calib::CornerObservation> obs = calib::ReadObservationsCsv(o.obs_path);
  const std::vector<calib::View> views = calib::GroupIntoViews(obs);
  std::vector<calib::View> eye_views[2];
  for (const calib::View& v : views) eye_views[v.eye == 1 ? 1 : 0].push_back(v);
  fs::create_directories(o.out_dir);

  fitting::CalibrationResult result;
  result.software_version = OWLCAL_VERSION;
  result.inputs = {{"observations", fs::absolute(o.obs_path).string()},
                   {"observations_fnv1a64", Fnv1a64(o.obs_path)},
                   {"num_observations", obs.size()},
                   {"options",
                    {{"model", o.model},
                     {"loss", o.loss},
                     {"corner_sigma_px", o.sigma_px},
                     {"outlier_threshold_sigma", o.outlier_sigma},
                     {"fix_k3", o.fix_k3},
                     {"fix_aspect_ratio", o.fix_aspect},
                     {"fix_tangential", o.fix_tangential},
                     {"fix_principal_point", o.fix_pp},
                     {"width", o.width},
                     {"height", o.height},
                     {"length_unit", sopt.length_unit}}}};
  bool usable = false;
  fitting::OpenCvStereoCalibration cv_file;
  cv_file.image_width = o.width;
  cv_file.image_height = o.height;
  if (!eye_views[0].empty() && !eye_views[1].empty()) {
    const fitting::StereoFit fit = fitting::FitStereo(eye_views[0], eye_views[1], sopt);
    fitting::AppendStereoToResult(fit, &result);
    std::cout << "stereo: " << fit.message << "\n";
    if (fit.ok) {
      // Physical sanity of the stereo result (evaluation/stereo_sanity.h): owl for a metric target.
      const bool metric = sopt.length_unit == "m" || sopt.length_unit == "mm";
      evaluation::RigExpectation rig;
      if (o.rig == "owl" || (o.rig == "auto" && metric))
        rig = evaluation::RigExpectation::Owl();
      else if (o.rig == "generic" || o.rig == "auto")
        rig = evaluation::RigExpectation::Generic();
      else
        throw UsageError("--rig = '" + o.rig + "': use auto, owl or generic");
      const double unit_m = sopt.length_unit == "m" ? 1.0 : (sopt.length_unit == "mm" ? 0.001 : 0.0);
      if (o.rig == "auto") {  // plainly not an Owl: judged as a generic pair, said once
        const std::string why_not = evaluation::WhyNotThisRig(fit.cameras, fit.right_from_left, unit_m, rig);
        if (!why_not.empty()) {
          rig = evaluation::RigExpectation::Generic();
          std::cout << "rig: not an owl (" << why_not << "), so judged as a generic stereo pair; --rig owl judges it "
                    << "against the owl rig\n";
        }
      }
      const evaluation::StereoSanity sanity =
          evaluation::CheckStereoSanity(fit.cameras, fit.right_from_left, unit_m, rig);
      evaluation::AppendSanityToResult(sanity, rig, &result);
      for (const auto& f : sanity.findings)
        std::cout << "sanity (" << (f.unusable ? "unusable" : "poor") << "): " << f.message << "\n";
      cv_file = fitting::ToOpenCvCalibration(fit);
      usable = !sanity.mirrored_or_swapped;
    } else {
      for (int e = 0; e < 2; ++e)
        if (fit.per_eye[e].ok) usable = true;
    }
  } else {
    for (int e = 0; e < 2; ++e) {
      if (eye_views[e].empty()) {
        result.warnings.push_back(std::string(e == 0 ? "left" : "right") +
                                  " eye: no observations; its intrinsics and the stereo extrinsics are not determined");
        continue;
      }
      const fitting::IntrinsicsFit fit = fitting::FitIntrinsics(eye_views[e], o.width, o.height, iopt);
      fitting::AppendIntrinsicsToResult(fit, e == 0 ? "left" : "right", &result);
      std::cout << (e == 0 ? "left" : "right") << ": " << fit.message << "\n";
      if (!fit.ok) continue;
      usable = true;
      const auto& p = fit.camera.params;
      cv::Mat M = (cv::Mat_<double>(3, 3) << p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
      cv::Mat D = cv::Mat(std::vector<double>(p.begin() + 4, p.end()), true).reshape(1, 1);
      (e == 0 ? cv_file.M1 : cv_file.M2) = M;
      (e == 0 ? cv_file.D1 : cv_file.D2) = D;
    }
  }
  const std::string json_path = (fs::path(o.out_dir) / "results.json").string();
  fitting::WriteResultJson(result, json_path);
  std::cout << "parameters:\n";
  PrintParameters(result);
  for (const std::string& w : result.warnings) std::cout << "warning: " << w << "\n";
  std::cout << "wrote " << json_path << "\n";
  if (usable) {
    const std::string yaml_path = (fs::path(o.out_dir) / "calibration.yaml").string();
    fitting::WriteOpenCvCalibration(yaml_path, cv_file);
    std::cout << "wrote " << yaml_path << "\n";
  }
  return usable ? kExitOk : kExitFailed;
}

const bool kFitRegistered = RegisterCommand(
    "fit",
    "Fit intrinsics per eye (and stereo R, T when both eyes are observed) from an observation CSV. "
    "Produces DIR/results.json (every value with sigma) and DIR/calibration.yaml (OpenCV M1 D1 M2 D2 R T E F R1 R2 P1 "
    "P2 Q).",
    [](CLI::App* cmd) {
      auto o = std::make_shared<FitCmdOptions>();
      cmd->add_option("observations", o->obs_path, "observation CSV from `owlcal detect`")->required();
      cmd->add_option("--out", o->out_dir, "output folder")->required();
      cmd->add_option("--model", o->model, "distortion model: opencv5 (k1 k2 p1 p2 k3) or opencv8 (+k4 k5 k6)");
      cmd->add_option(
             "--rig", o->rig, "sanity checks of a stereo result: owl, generic or auto (owl for a metric target)")
          ->capture_default_str();
      cmd->add_option("--loss", o->loss, "robust loss: none, huber or cauchy");
      cmd->add_option("--corner-sigma-px", o->sigma_px, "corner noise [px]; 0 = estimate from the residuals");
      cmd->add_option("--outlier-sigma", o->outlier_sigma, "reject corners beyond this many sigma (0 = off)");
      cmd->add_option("--target", o->target_path, "target file (for the length unit of the board)");
      cmd->add_option("--unit", o->unit, "length unit of the board points (m, or e.g. square)");
      cmd->add_option("--width", o->width, "image width per eye [px]");
      cmd->add_option("--height", o->height, "image height per eye [px]");
      cmd->add_flag("--fix-k3", o->fix_k3, "hold k3 at 0");
      cmd->add_flag("--fix-aspect", o->fix_aspect, "fy = fx");
      cmd->add_flag("--fix-tangential", o->fix_tangential, "hold p1, p2 at 0");
      cmd->add_flag("--fix-principal-point", o->fix_pp, "hold cx, cy at the image centre");
      return [o] { return RunFit(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
