// owlcal pose-calibration --calib DIR Rx Ry Lx Ly Neck [--out OUT]: the stereo calibration at
// any servo command, predicted from DIR's head fit with sigma (fitting/pose_stereo.h), written
// as the centre pose's files: results.json, calibration.yaml, intrinsics.xml, extrinsics.xml and
// exports/ (reports/exports.h).
#include <filesystem>
#include <iostream>
#include <memory>

#include "apps/calibration_output.h"
#include "apps/command_registry.h"
#include "apps/output_folder.h"
#include "evaluation/truth_compare.h"
#include "fitting/format.h"
#include "fitting/pose_stereo.h"
#include "reports/exports.h"
#include "reports/report_data.h"

namespace owlcal::apps {
namespace {

namespace fs = std::filesystem;
using fitting::FixedOrDash;

struct PoseCalibrationOptions {
  std::string calib, out;
  std::vector<int> pwm;
  std::vector<int> approach;
  double alpha = -1;
};

int RunPoseCalibration(const PoseCalibrationOptions& a) {
  if (a.pwm.size() != models::kNumServos) throw UsageError("give five pulse widths: Rx Ry Lx Ly Neck");
  if (!a.approach.empty() && a.approach.size() != models::kNumServos)
    throw UsageError("--approach takes five values (-1, 0, +1) in wire order");
  std::string out = a.out;
  if (out.empty()) {
    out = (fs::path(a.calib) / "pose").string();
    for (int p : a.pwm) out += "-" + std::to_string(p);
  }
  CheckInputOutsideRun(out, a.calib, "--calib");
  evaluation::CalibrationRun run = reports::ReadReportData(a.calib);
  models::PwmVector pwm{};
  for (int i = 0; i < models::kNumServos; ++i) {
    const auto& s = run.config.servos[i];
    if (a.pwm[i] < s.min_us || a.pwm[i] > s.max_us)
      throw UsageError(std::string(models::kServoNames[i]) + " = " + std::to_string(a.pwm[i]) +
                       " us is outside this robot's limits " + std::to_string(s.min_us) + "-" +
                       std::to_string(s.max_us) + " us (" + a.calib + "/evaluation.json)");
    pwm[i] = a.pwm[i];
  }
  fitting::PoseStereoOptions o;
  for (size_t i = 0; i < a.approach.size(); ++i) o.approach[i] = a.approach[i];
  o.rectify_alpha = a.alpha;
  std::string why;
  if (!o.Check(&why)) throw UsageError(why);
  // The pose's folder holds this run alone, as a calibration run's (apps/output_folder.h): a
  // prediction that fails leaves no earlier one looking current.
  const std::string run_id = StartRun(out, [](const std::string& m) { std::cout << m << "\n"; });
  const fitting::PoseStereo s = fitting::StereoAtPose(run.result, pwm, o);
  if (!s.ok) {
    std::cerr << "owlcal pose-calibration: " << a.calib << ": " << s.message << "\n";
    return kExitFailed;
  }
  evaluation::CalibrationRun pr;
  pr.result = s.result;
  StampRun(run_id, &pr.result);
  pr.result.inputs["calibration"] = a.calib;
  pr.result.inputs["calibration_run_id"] = run.result.run_id;  // the head fit's run
  pr.config = run.config;
  pr.limits = run.limits;
  pr.truth = run.truth;
  if (run.truth) {
    const auto truth = evaluation::StereoTruthValues(*run.truth, pwm, o.approach);
    evaluation::FillTruth(truth, &pr.result);
  }
  fitting::WriteResultJson(pr.result, (fs::path(out) / "results.json").string());
  const reports::ExportSet ex = reports::WriteCalibrationFiles(pr, out);

  std::cout << "Stereo at Rx Ry Lx Ly Neck = " << a.pwm[0] << " " << a.pwm[1] << " " << a.pwm[2] << " " << a.pwm[3]
            << " " << a.pwm[4] << " us, from the head fit in " << a.calib << " (sigma from " << s.propagated.size()
            << " head parameters"
            << (s.not_propagated.empty()
                    ? ""
                    : "; " + std::to_string(s.not_propagated.size()) + " not determined, not in it")
            << "):\n\n| parameter | value | sigma | unit |" << (run.truth ? " truth | z |" : "")
            << "\n|---|---|---|---|" << (run.truth ? "---|---|" : "") << "\n";
  for (const char* n : {"stereo.rx_deg",
                        "stereo.ry_deg",
                        "stereo.rz_deg",
                        "stereo.tx",
                        "stereo.ty",
                        "stereo.tz",
                        "stereo.baseline_mm"}) {
    const fitting::Parameter* p = pr.result.Find(n);
    if (!p) continue;
    std::cout << "| " << n << " | " << FixedOrDash(p->value, 4) << " | " << FixedOrDash(p->sigma, 4) << " | " << p->unit
              << " |";
    if (run.truth && p->truth)
      std::cout << " " << FixedOrDash(*p->truth, 4) << " | " << FixedOrDash((p->value - *p->truth) / p->sigma, 2)
                << " |";
    std::cout << "\n";
  }
  for (const auto& sk : ex.skipped) std::cout << "export skipped: " << sk << "\n";
  std::cout << "\nwrote " << out << ": results.json";
  for (const auto& w : ex.written) std::cout << " " << fs::relative(w, out).string();
  std::cout << "\n";
  return kExitOk;
}

const bool kPoseCalibrationRegistered = RegisterCommand(
    "pose-calibration",
    "The stereo calibration (R, T, E, F, rectification R1 R2 P1 P2, Q) at any servo command, predicted\n"
    "from a calibration folder's head fit (owlcal calibrate), with sigma propagated from the head fit's\n"
    "covariance. Writes results.json, calibration.yaml (metres), intrinsics.xml/extrinsics.xml (mm) and\n"
    "exports/ into --out, as for the centre pose; on the virtual Owl it prints the truth at that command.",
    [](CLI::App* cmd) {
      auto o = std::make_shared<PoseCalibrationOptions>();
      cmd->add_option("--calib", o->calib, "calibration folder with results.json and evaluation.json")
          ->required()
          ->check(CLI::ExistingDirectory);
      cmd->add_option("pwm", o->pwm, "pulse widths Rx Ry Lx Ly Neck [us]")->required()->expected(5);
      cmd->add_option("--out", o->out, "output folder (default CALIB/pose-Rx-Ry-Lx-Ly-Neck)");
      cmd->add_option("--approach",
                      o->approach,
                      "per servo, the side each was approached from: +1 from below, -1 from above, 0 unknown (the "
                      "backlash band is then in the sigma); default all 0")
          ->expected(5);
      cmd->add_option("--alpha", o->alpha, "cv::stereoRectify alpha (-1 OpenCV's default, 0..1)")
          ->capture_default_str();
      return [o] { return RunPoseCalibration(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
