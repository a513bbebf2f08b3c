// A small version of bench/robot_prior_mc_bench.cc: robots drawn from the
// prior of real Owls (sim/robot_prior.h: wide and narrow lenses, 1 or 5 us PWM steps, dead
// bands, bowed boards, noisy streams), each recorded on the in-process virtual Owl with the
// standard intrinsics, stereo and servo-sweep protocols and calibrated by pipeline::Calibrate
// with calibrate's defaults (pipeline/calibrate.h); every fitted parameter with a truth is scored as
// z = (value - truth) / sigma and pooled per group (lens, stereo, servo maps, head geometry).
// Honest sigmas put 68 % within 1 sigma and 99.7 % within 3; the bounds below are loose for
// a few robots, yet the same fits with every sigma 3 x too large or 2 x too small fail them.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "calib/trial_status.h"
#include "fitting/monte_carlo.h"
#include "owlcal_version.h"
#include "pipeline/calibrate.h"
#include "sim/robot_prior.h"
#include "sim/virtual_owl.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;

constexpr int kNumRobots = 6;

// The short stereo and servo-sweep protocols (about 90 frames instead of 280); the bench runs
// them over many robots: robot_prior_mc_bench 30 1 tests/data/protocols/mc_stereo.yaml
// tests/data/protocols/mc_servo_sweep.yaml.
const std::string kProtocols = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/";

// Why a group's coverage is not that of honest sigmas ("" when it is): within 1 sigma
// 68.3 % +- max(15 %, 3 binomial sd), within 3 sigma at least 93 %.
std::string CoverageProblem(const fitting::SigmaCoverage::Group& g) {
  if (g.count < 20) return "only " + std::to_string(g.count) + " scored";
  const double f1 = double(g.within1) / g.count, f3 = double(g.within3) / g.count;
  const double tol = std::max(0.15, 3 * std::sqrt(0.683 * 0.317 / g.count));
  if (std::abs(f1 - 0.683) > tol)
    return std::to_string(int(100 * f1)) + " % within 1 sigma (68 +- " + std::to_string(int(100 * tol)) + ")";
  if (f3 < 0.93) return std::to_string(int(100 * f3)) + " % within 3 sigma (< 93)";
  return "";
}

// The coverage of `fits` with every sigma multiplied by `factor`.
fitting::SigmaCoverage Pool(const std::vector<std::vector<fitting::Parameter>>& fits, double factor) {
  fitting::SigmaCoverage c;
  for (size_t i = 0; i < fits.size(); ++i) {
    std::vector<fitting::Parameter> p = fits[i];
    for (auto& q : p) q.sigma *= factor;
    c.SetLabel("robot " + std::to_string(i + 1));
    c.Add(p);
  }
  return c;
}

// The robot on the in-process virtual Owl, calibrated by pipeline::Calibrate with calibrate's
// defaults on `protocols`; every protocol must complete.
evaluation::CalibrationRun CalibrateRobot(const sim::DrawnRobot& robot,
                                          uint64_t seed,
                                          const fs::path& root,
                                          const std::vector<std::string>& protocols) {
  sim::VirtualOwl owl(robot.OwlOptions(seed));
  pipeline::CalibrateOptions co;
  co.out = (root / robot.truth.name).string();
  co.protocols = protocols;
  co.robot.sim = {{"seed", seed}};
  evaluation::CalibrationRun run = pipeline::Calibrate(owl, co);
  for (const auto& [name, r] : run.settings.at("runs").items())
    EXPECT_EQ(r.at("status"), "complete") << robot.truth.name << " " << name << ": " << r.at("message");
  return run;
}

TEST(RobotPriorMonteCarlo, SigmasCoverTheErrorsOnRobotsOfThePrior) {
  const fs::path root = fs::temp_directory_path() / ("owlcal_prior_mc_test_" + std::to_string(::getpid()));
  fs::remove_all(root);
  std::vector<std::vector<fitting::Parameter>> fits;
  for (int i = 1; i <= kNumRobots; ++i) {
    std::mt19937_64 rng(uint64_t(i) * 7919 + 17);  // as the bench's robot i
    const sim::DrawnRobot robot = sim::DrawRobot(&rng, "prior-" + std::to_string(i));
    // The standard protocols that fit parameters, calibrated as `owlcal calibrate` does (the short
    // ones, which the ranging test below uses, put the servo maps 89 % within 1 sigma: their 8
    // stereo views make the stereo fit's intrinsics floor noise-limited).
    const evaluation::CalibrationRun run =
        CalibrateRobot(robot, uint64_t(i), root, {"intrinsics", "stereo", "servo_sweep"});
    int scored = 0;
    for (const auto& p : run.result.parameters) {
      if (!(p.determined && p.truth && p.sigma > 0)) continue;
      ++scored;
      const double z = (p.value - *p.truth) / p.sigma;
      if (std::abs(z) > 3)
        std::printf("  %s: %s = %.6g, truth %.6g, sigma %.3g: z %+.1f\n",
                    robot.truth.name.c_str(),
                    p.name.c_str(),
                    p.value,
                    *p.truth,
                    p.sigma,
                    z);
    }
    std::printf("%s: f %.0f/%.0f px, quantum %d us, noise %.1f, warp %.2f mm: %d parameters scored\n",
                robot.truth.name.c_str(),
                robot.truth.intrinsics[0].params[0],
                robot.truth.intrinsics[1].params[0],
                robot.truth.servos[0].quantum_us,
                robot.truth.stream.noise_sigma,
                1000 * robot.scene.Find("chessboard")->warp_m.x(),
                scored);
    EXPECT_GT(scored, 60) << robot.truth.name;
    fits.push_back(run.result.parameters);
  }
  fs::remove_all(root);

  const fitting::SigmaCoverage coverage = Pool(fits, 1.0);
  std::printf("%s\n", coverage.GroupTable().c_str());
  for (const char* group : {"lens", "stereo", "servo maps", "head geometry"}) {
    ASSERT_TRUE(coverage.per_group().count(group)) << group;
    EXPECT_EQ(CoverageProblem(coverage.per_group().at(group)), "") << group;
  }
  // The bounds can fail: the same fits with dishonest sigmas.
  for (const double factor : {3.0, 0.5}) {
    const fitting::SigmaCoverage wrong = Pool(fits, factor);
    int failing = 0;
    for (const auto& [group, g] : wrong.per_group()) failing += !CoverageProblem(g).empty();
    EXPECT_EQ(failing, int(wrong.per_group().size())) << "sigma x " << factor << " passes in some group";
  }
}

// A small version of bench/ranging_population_bench.cc: two robots of the prior with eye dead
// bands redrawn in 1-5 us, one with 5 us PWM steps and one with 1 us, each recorded with the short
// stereo and sweep protocols above, the resolution sweep (tests/data/protocols/resolution_probe.yaml)
// and five fixations (vergence_short.yaml), and calibrated by calibrate's pipeline. At least 4 of 5
// fixations ranged on each (an unranged one is a row with its reason), ranging within 1 % RMS on
// each, and at least 8 of the ranged fixations within 2 predicted sigma.
TEST(RobotPriorMonteCarlo, RangingWithinOnePercentWithDeadBandsAndPwmSteps) {
  const fs::path root = fs::temp_directory_path() / ("owlcal_prior_ranging_test_" + std::to_string(::getpid()));
  fs::remove_all(root);
  int pooled = 0, within = 0;
  for (const uint64_t seed : {1, 2}) {
    std::mt19937_64 rng(seed * 7919 + 17);  // as the bench's robot `seed`
    sim::DrawnRobot robot = sim::DrawRobot(&rng, "population-" + std::to_string(seed));
    std::uniform_int_distribution<int> dead_band(1, 5);
    for (int s = 0; s < models::kNumServos; ++s) {
      robot.truth.servos[s].quantum_us = seed % 2 ? 5 : 1;
      if (s != models::kNeck) robot.truth.servos[s].dead_band_us = dead_band(rng);
    }
    const evaluation::CalibrationRun run = CalibrateRobot(robot,
                                                          seed,
                                                          root,
                                                          {kProtocols + "mc_stereo.yaml",
                                                           kProtocols + "mc_servo_sweep.yaml",
                                                           kProtocols + "resolution_probe.yaml",
                                                           kProtocols + "vergence_short.yaml"});
    ASSERT_TRUE(run.ranging) << robot.truth.name;
    int n = 0, in = 0;
    for (const auto& row : run.ranging->rows) {
      if (!row.ok) {
        std::printf("  %s: %.2f m not ranged: %s: %s\n",
                    robot.truth.name.c_str(),
                    row.true_m,
                    calib::TrialStatusName(row.status),
                    row.reason.c_str());
        EXPECT_FALSE(row.reason.empty()) << robot.truth.name;
        continue;
      }
      ++n;
      in += std::abs(row.error_m) <= 2 * row.sigma_m;
    }
    std::printf(
        "%s: step %d us, dead bands %.0f/%.0f/%.0f/%.0f us: %d ok of %zu, RMS %.3f %%, max %.3f %%, %d within 2 "
        "sigma\n",
        robot.truth.name.c_str(),
        robot.truth.servos[0].quantum_us,
        robot.truth.servos[0].dead_band_us,
        robot.truth.servos[1].dead_band_us,
        robot.truth.servos[2].dead_band_us,
        robot.truth.servos[3].dead_band_us,
        run.ranging->num_ok,
        run.ranging->rows.size(),
        100 * run.ranging->rms_rel_error,
        100 * run.ranging->max_abs_rel_error,
        in);
    EXPECT_GE(run.ranging->num_ok, 4) << robot.truth.name;  // an unranged fixation is a row with its reason
    EXPECT_LE(run.ranging->rms_rel_error, 0.01) << robot.truth.name;
    pooled += n;
    within += in;
  }
  EXPECT_GE(within, 8) << "of " << pooled;
  fs::remove_all(root);
}

}  // namespace
}  // namespace owlcal
