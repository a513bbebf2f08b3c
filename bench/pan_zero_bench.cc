// Where do the pan maps' errors come from? ("every servo's map within 0.1 deg RMS
// over its range".) Fits the head on a recorded servo_sweep dataset of the DEFAULT virtual Owl
// (e.g. CALDIR/datasets/servo_sweep of `owlcal calibrate`) several ways and compares every
// servo's map with the truth in the fit's gauge (fitting::CanonicalHead) over the robot file's
// whole range, split into the constant offset (for the pans: the head-yaw gauge, i.e. how well
// the eye centres' z difference is known) and the rest (scale, nonlinear terms):
//   truth-held      true intrinsics held (the data's own limit)
//   result-held     intrinsics of RESULT_JSON held (what calibrate does)
//   result-prior    intrinsics of RESULT_JSON as a Gaussian prior (diagonal sigmas), refined
//   free            intrinsics free (from RESULT_JSON's values, else the truth)
// Usage: pan_zero_bench SWEEP_DATASET_DIR [RESULT_JSON|-] [corner_sigma_px=0.15] [ROBOT_TRUTH_FILE]
// (the truth file the dataset was recorded with, `owlcal run --robot-truth`; default: the built-in robot)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "fitting/head_fit.h"
#include "fitting/result.h"
#include "models/servo_map.h"
#include "protocols/placement_views.h"
#include "sim/robot_truth.h"

using namespace owlcal;

namespace {

void Report(const char* label,
            const fitting::HeadFit& fit,
            const models::HeadModel& canonical,
            const models::RobotConfig& config) {
  if (!fit.ok) {
    std::printf("%-13s FAILED: %s\n", label, fit.message.c_str());
    return;
  }
  auto sigma_of = [&](const std::string& name) {
    const fitting::Parameter* p = fit.result.Find(name);
    return p ? p->sigma : std::nan("");
  };
  std::printf("%-13s RMS %.4f px, IPD %.3f mm (truth %.3f), %.1f s\n",
              label,
              fit.result.summaries.back().rms_px,
              1000 * fit.head.geometry.Ipd(),
              1000 * canonical.geometry.Ipd(),
              fit.result.summaries.back().time_s);
  for (int s = 0; s < models::kNumServos; ++s) {
    const auto& lim = config.servos[s];
    const double* f = fit.head.servo_params[s].data();
    const double* t = canonical.servo_params[s].data();
    const int dir = canonical.directions[s];
    double mean = 0, sum_sq = 0;
    for (int i = 0; i <= 200; ++i) {
      const double u = lim.min_us + (lim.max_us - lim.min_us) * i / 200.0;
      const double d =
          (models::ServoMap::JointAngle(f, dir, u, 0) - models::ServoMap::JointAngle(t, dir, u, 0)) * 180 / M_PI;
      mean += d / 201;
      sum_sq += d * d / 201;
    }
    const std::string n = std::string("servo.") + models::kServoNames[s] + ".";
    std::printf(
        "  %-4s map RMS %.4f deg = offset %+.4f (+) rest %.4f; centre err %+.2f us (sigma %.2f), cubic err %+.3f "
        "(sigma %.3f)\n",
        models::kServoNames[s],
        std::sqrt(sum_sq),
        mean,
        std::sqrt(std::max(0.0, sum_sq - mean * mean)),
        f[0] - t[0],
        sigma_of(n + "centre_us"),
        f[3] - t[3],
        sigma_of(n + "cubic_deg"));
  }
  const auto tp = fitting::HeadParameters(canonical, true);
  int n = 0, in1 = 0, in2 = 0, in3 = 0;
  std::string worst;
  double worst_z = 0;
  for (const auto& p : fit.result.parameters) {
    if (!p.determined || !(p.sigma > 0)) continue;
    for (const auto& t : tp) {
      if (t.name != p.name) continue;
      const double z = std::abs(p.value - t.value) / p.sigma;
      ++n;
      in1 += z <= 1;
      in2 += z <= 2;
      in3 += z <= 3;
      if (z > worst_z) worst_z = z, worst = p.name;
    }
  }
  std::printf(
      "  parameters: %d with sigma: %.0f %% within 1 sigma, %.0f %% within 2, %.0f %% within 3; worst %s z %.2f\n",
      n,
      100.0 * in1 / std::max(1, n),
      100.0 * in2 / std::max(1, n),
      100.0 * in3 / std::max(1, n),
      worst.c_str(),
      worst_z);
  for (const char* name : {"head.left.centre_z_mm", "head.right.centre_x_mm", "head.left.fx", "head.right.fx"}) {
    const fitting::Parameter* p = fit.result.Find(name);
    for (const auto& t : tp)
      if (p && t.name == name)
        std::printf("  %-24s %.4f (truth %.4f, sigma %.4f)\n", name, p->value, t.value, p->sigma);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr,
                 "usage: pan_zero_bench SWEEP_DATASET_DIR [RESULT_JSON|-] [corner_sigma_px=0.15] [ROBOT_TRUTH_FILE]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const std::string result_json = argc > 2 && std::string(argv[2]) != "-" ? argv[2] : "";
  const double sigma = argc > 3 ? std::atof(argv[3]) : 0.15;
  const sim::RobotTruth truth_robot = argc > 4 ? sim::LoadRobotTruth(argv[4]) : sim::DefaultRobotTruth();
  const models::RobotConfig& config = truth_robot.robot;
  const models::HeadModel truth = truth_robot.HeadModel();
  const auto views = protocols::ReadViewsByPlacement(dir);
  bool neck_moved = false;
  for (const auto& v : views) neck_moved |= v.pwm_us[models::kNeck] != config.servos[models::kNeck].centre_us;
  models::HeadModel initial = models::NominalHeadModel(config);
  const models::HeadModel canonical = fitting::CanonicalHead(
      truth, config.servos[models::kNeck].centre_us, neck_moved, initial.geometry.centre_in_head[models::kLeftEye]);
  std::printf("%zu views, corner sigma %.3f px\n", views.size(), sigma);
  fitting::HeadFitOptions ho;
  ho.corner_sigma_px = sigma;
  {
    models::HeadModel init = initial;
    for (int e = 0; e < 2; ++e) init.intrinsics[e] = truth.intrinsics[e];
    Report("truth-held", fitting::FitHead(views, config, init, ho), canonical, config);
    if (result_json.empty()) {
      fitting::HeadFitOptions fo = ho;
      fo.fit_intrinsics = true;
      Report("truth-free", fitting::FitHead(views, config, init, fo), canonical, config);
    }
  }
  if (!result_json.empty()) {
    const fitting::CalibrationResult r = fitting::ReadResultJson(result_json);
    models::HeadModel init = initial;
    for (int e = 0; e < 2; ++e) {
      if (!r.cameras[e]) {
        std::fprintf(stderr, "%s: no %s camera\n", result_json.c_str(), models::kEyeNames[e]);
        return 1;
      }
      init.intrinsics[e] = *r.cameras[e];
      std::printf("%s intrinsics error:", models::kEyeNames[e]);
      for (size_t k = 0; k < init.intrinsics[e].params.size(); ++k)
        std::printf(" %+.4g", init.intrinsics[e].params[k] - truth.intrinsics[e].params[k]);
      std::printf("\n");
    }
    Report("result-held", fitting::FitHead(views, config, init, ho), canonical, config);
    fitting::HeadFitOptions po = ho;
    po.fit_intrinsics = true;
    const auto names = fitting::HeadParameters(init, true);
    for (int e = 0; e < 2; ++e) {
      const int n = int(init.intrinsics[e].params.size());
      Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
      static const char* kNames[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
      bool ok = true;
      for (int k = 0; k < n; ++k) {
        const fitting::Parameter* p = r.Find(std::string(models::kEyeNames[e]) + "." + kNames[k]);
        if (!p) p = r.Find(std::string("head.") + models::kEyeNames[e] + "." + kNames[k]);
        if (!p || !(p->sigma > 0)) {
          ok = false;
          break;
        }
        cov(k, k) = p->sigma * p->sigma;
      }
      if (ok)
        po.intrinsics_prior_covariance[e] = cov;
      else
        std::printf("no sigmas for the %s intrinsics in %s: no prior\n", models::kEyeNames[e], result_json.c_str());
    }
    Report("result-prior", fitting::FitHead(views, config, init, po), canonical, config);
    fitting::HeadFitOptions fo = ho;
    fo.fit_intrinsics = true;
    Report("free", fitting::FitHead(views, config, init, fo), canonical, config);
  }
  return 0;
}
