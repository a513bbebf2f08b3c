// Honest-sigma benchmark for the head fit: over >= 50 seeds, a perturbed
// head (fitting/head_synthetic.h) is swept like the servo-sweep protocol, corners get 0.15 px
// Gaussian noise, the head is fitted, and every determined parameter is compared with the
// truth in units of its reported sigma. Prints the fraction within 1 sigma (target 68 +- 7 %)
// and within 3 sigma (target >= 98 %), per-parameter coverage, IPD and servo-map errors, and
// fit time. Usage: head_sigma_bench [num_seeds=50] [steps_per_sweep=6] [grid_side=4]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <stdexcept>
#include <vector>

#include "evaluation/servo_map_eval.h"
#include "fitting/head_fit.h"
#include "fitting/head_synthetic.h"
#include "fitting/monte_carlo.h"
#include "models/head_model.h"

int main(int argc, char** argv) {
  using namespace owlcal;
  const int num_seeds = argc > 1 ? std::atoi(argv[1]) : 50;
  fitting::SyntheticHeadOptions so;
  so.steps_per_sweep = argc > 2 ? std::atoi(argv[2]) : 6;
  so.grid_side = argc > 3 ? std::atoi(argv[3]) : 4;
  const models::RobotConfig robot = models::DefaultRobotConfig();
  std::vector<double> ipd_err_mm, map_rms_deg, times_s;
  double worst_map = 0;
  const fitting::SigmaCoverage coverage = fitting::RunMonteCarlo(num_seeds, 1000, [&](uint64_t seed) {
    std::mt19937_64 rng(seed);
    const models::HeadModel truth = fitting::PerturbedHead(robot, &rng, /*mount_pitch_deg_sigma=*/1.0, false);
    const fitting::SyntheticHeadData data = fitting::SynthesizeHeadViews(truth, robot, so, &rng);
    models::HeadModel init = models::NominalHeadModel(robot);
    init.intrinsics[0] = truth.intrinsics[0];
    init.intrinsics[1] = truth.intrinsics[1];
    fitting::HeadFit fit = fitting::FitHead(data.views, robot, init, fitting::HeadFitOptions());
    if (!fit.ok) throw std::runtime_error(fit.message);
    times_s.push_back(fit.result.summaries[0].time_s);
    const models::HeadModel canon = fitting::CanonicalHead(
        truth, robot.servos[models::kNeck].centre_us, true, init.geometry.centre_in_head[models::kLeftEye]);
    fitting::SetHeadTruth(canon, &fit.result);
    ipd_err_mm.push_back(fit.result.Find("head.ipd_mm")->value - canon.geometry.Ipd() * 1000);
    for (int s = 0; s < models::kNumServos; ++s) {
      const double rms = evaluation::ServoMapRmsDeg(fit.head.servo_params[s].data(),
                                                    canon.servo_params[s].data(),
                                                    robot.servos[s].direction,
                                                    robot.servos[s].min_us,
                                                    robot.servos[s].max_us);
      map_rms_deg.push_back(rms);
      worst_map = std::max(worst_map, rms);
    }
    std::printf("seed %llu: rms %.3f px, ipd err %+.3f mm +- %.3f, %.2f s\n",
                (unsigned long long)seed,
                fit.result.summaries[0].rms_px,
                ipd_err_mm.back(),
                fit.result.Find("head.ipd_mm")->sigma,
                times_s.back());
    std::fflush(stdout);
    return fit.result.parameters;
  });
  std::printf("\n== head_sigma_bench: %d seeds, %d steps per sweep, %dx%d grid, neck moved, noise 0.15 px ==\n",
              num_seeds,
              so.steps_per_sweep,
              so.grid_side,
              so.grid_side);
  std::printf("%s", coverage.Report().c_str());
  auto rms = [](const std::vector<double>& v) {
    double s = 0;
    for (double x : v) s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / v.size());
  };
  double max_ipd = 0;
  for (double e : ipd_err_mm) max_ipd = std::max(max_ipd, std::abs(e));
  std::sort(times_s.begin(), times_s.end());
  std::printf("IPD error: RMS %.3f mm, max %.3f mm (target 0.5)\n", rms(ipd_err_mm), max_ipd);
  std::printf(
      "servo map error over the range: RMS %.4f deg, worst %.4f deg (target 0.1)\n", rms(map_rms_deg), worst_map);
  if (!times_s.empty())
    std::printf("fit time: median %.2f s, max %.2f s\n", times_s[times_s.size() / 2], times_s.back());
  const double f1 = coverage.FractionWithin(1), f3 = coverage.FractionWithin(3);
  std::printf("VERDICT within-1-sigma %.1f %% %s, within-3-sigma %.2f %% %s\n",
              100 * f1,
              std::abs(f1 - 0.683) <= 0.07 ? "OK" : "OUT OF 68+-7",
              100 * f3,
              f3 >= 0.98 ? "OK" : "BELOW 98");
  return 0;
}
