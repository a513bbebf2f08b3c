// Monte-Carlo check of owlcal's sigmas over robots drawn from the prior of real Owls
// (sim/robot_prior.h): each robot runs the whole calibration (`owlcal calibrate` on the virtual
// Owl with that robot truth and board, the protocols that fit parameters: intrinsics, stereo,
// servo_sweep), and every fitted parameter with a truth is scored as z = (value - truth) / sigma.
// Prints one line per robot and the pooled coverage per parameter group (lens, stereo, servo
// maps, head geometry): target 68 +- 5 % within 1 sigma, >= 99 % within 3 sigma.
// Run it under `nice`: one robot is about 20 s of CPU with the standard protocols (16 s wall alone
// on 2 cores, measured on prior-1 at ac925cd: capture 7.7 s, lens-model choice 5.4 s, head fit
// 2.4 s); OWLCAL_MC_JOBS robots (default 2) run at once, so 30 robots take about 10 minutes on a
// quiet 2-core machine.
//
// Usage: robot_prior_mc_bench [num_robots=30] [first_seed=1] [protocol ...]
//        robot_prior_mc_bench shipped [seeds_per_robot=1] [first_seed=1] [protocol ...]
// `shipped`: the three robots in data/sim (default, variant a, variant b) instead of drawn ones.
// OWLCAL_MC_KEEP=1 keeps each robot's observations and manifests (not the frames) under the temp
// folder, for refits (`owlcal fit-datasets DIR/cal --out ...`); OWLCAL_MC_PER_PARAMETER=1 adds
// the per-parameter table; OWLCAL_MC_JOBS=N runs N robots at once (the output is the same).
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fitting/monte_carlo.h"
#include "fitting/result.h"
#include "owlcal_version.h"
#include "sim/robot_prior.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  using namespace owlcal;
  const bool shipped = argc > 1 && std::string(argv[1]) == "shipped";
  const char* const kShipped[3] = {"owl_default_truth.yaml", "owl_variant_a_truth.yaml", "owl_variant_b_truth.yaml"};
  const int per_robot = shipped ? (argc > 2 ? std::atoi(argv[2]) : 1) : 1;
  const int num_robots = shipped ? 3 * per_robot : (argc > 1 ? std::atoi(argv[1]) : 30);
  const uint64_t first_seed = argc > 2 + shipped ? std::strtoull(argv[2 + shipped], nullptr, 10) : 1;
  if (num_robots < 1) {
    std::fprintf(stderr, "robot_prior_mc_bench: need at least one robot\n");
    return 2;
  }
  std::vector<std::string> protocols;
  for (int i = 3 + shipped; i < argc; ++i) protocols.push_back(argv[i]);
  if (protocols.empty()) protocols = {"intrinsics", "stereo", "servo_sweep"};
  const fs::path root = fs::temp_directory_path() / ("owlcal_prior_mc_" + std::to_string(first_seed));
  fs::remove_all(root);
  fs::create_directories(root);

  // One robot: draw it, run `owlcal calibrate` on it, score it. Robots are independent processes,
  // so OWLCAL_MC_JOBS (default 2) of them run at once; each robot's seed, files and result depend
  // only on its index, and the lines and the pooled table are made in robot order below, so the
  // output does not depend on the number of jobs.
  struct RobotRun {
    std::string name, line, failure;
    std::vector<fitting::Parameter> parameters;
  };
  auto run_robot = [&](int i) {
    RobotRun out;
    const uint64_t seed = first_seed + uint64_t(shipped ? i % per_robot : i);
    std::mt19937_64 rng(seed * 7919 + 17);
    std::string name = "prior-" + std::to_string(seed);
    sim::DrawnRobot robot = sim::DrawRobot(&rng, name);
    if (shipped) {
      const std::string file = kShipped[i / per_robot];
      robot.truth = sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/data/sim/" + file);
      robot.scene = sim::DefaultScene();
      name = file.substr(0, file.find("_truth")) + "-seed" + std::to_string(seed);
    }
    out.name = name;
    const fs::path dir = root / name;
    fs::create_directories(dir);
    sim::SaveRobotTruth(robot.truth, (dir / "truth.yaml").string());
    std::ofstream((dir / "scene.yaml").string()) << sim::SceneJson(robot.scene).dump(2);
    std::string cmd = std::string(OWLCAL_BINARY) + " calibrate --quiet --no-figures --robot-truth " +
                      (dir / "truth.yaml").string() + " --scene " + (dir / "scene.yaml").string() + " --seed " +
                      std::to_string(seed) + " --out " + (dir / "cal").string() + " --protocols";
    for (const auto& p : protocols) cmd += " " + p;
    cmd += " > " + (dir / "log.txt").string() + " 2>&1";
    const int rc = std::system(cmd.c_str());
    if (rc != 0 || !fs::exists(dir / "cal" / "results.json")) {
      out.failure = name + ": owlcal calibrate exited " + std::to_string(rc) + " (log " + (dir / "log.txt").string() + ")";
      out.line = name + ": FAILED (rc " + std::to_string(rc) + ")\n";
      return out;
    }
    const fitting::CalibrationResult r = fitting::ReadResultJson((dir / "cal" / "results.json").string());
    out.parameters = r.parameters;
    double worst = 0, sum = 0;
    int n = 0;
    std::string worst_name;
    for (const auto& p : r.parameters) {
      if (!p.determined || !p.truth || !(p.sigma > 0)) continue;
      const double z = (p.value - *p.truth) / p.sigma;
      sum += z * z;
      ++n;
      if (std::abs(z) > std::abs(worst)) worst = z, worst_name = p.name;
    }
    const auto& t = robot.truth;
    // The worst servo map against the truth over the robot file's range (tables/servo_map_truth.csv:
    // servo, range, RMS [deg], ...; acceptance: 0.05 deg) and the fitted bow against the board's.
    double worst_map = NAN;
    std::string worst_servo;
    {
      std::ifstream csv((dir / "cal" / "tables" / "servo_map_truth.csv").string());
      std::string line;
      std::getline(csv, line);
      while (std::getline(csv, line)) {
        std::vector<std::string> f;
        for (size_t a = 0, b; a <= line.size(); a = b + 1) {
          b = std::min(line.find(',', a), line.size());
          f.push_back(line.substr(a, b - a));
        }
        if (f.size() < 3) continue;
        const double rms = std::atof(f[2].c_str());
        if (!(rms <= worst_map)) worst_map = rms, worst_servo = f[0];
      }
    }
    const fitting::Parameter* bow = r.Find("head.board_warp_x_mm");
    char buf[1024];
    std::snprintf(buf, sizeof buf, "%s: f %.0f/%.0f px, quantum %d us, dead band %.1f us, noise %.1f, jpeg %d, warp %.2f mm (fitted %.3f) | "
                "%d scored, RMS(z) %.2f, worst %s z = %+.2f | servo maps worst %.4f deg RMS (%s)\n",
                name.c_str(), t.intrinsics[0].params[0], t.intrinsics[1].params[0], t.servos[0].quantum_us,
                t.servos[0].dead_band_us, t.stream.noise_sigma, t.stream.jpeg_quality,
                1000 * robot.scene.Find("chessboard")->warp_m.x(), bow ? bow->value : NAN, n, n ? std::sqrt(sum / n) : NAN,
                worst_name.c_str(), worst, worst_map, worst_servo.c_str());
    out.line = buf;
    // Keep results.json and the log, not the frames (OWLCAL_MC_KEEP: the observations too).
    if (std::getenv("OWLCAL_MC_KEEP")) {
      for (const auto& e : fs::recursive_directory_iterator(dir / "cal" / "datasets"))
        if (e.is_regular_file() && e.path().extension() != ".csv" && e.path().filename() != "manifest.json")
          fs::remove(e.path());
    } else {
      fs::remove_all(dir / "cal" / "datasets");
    }
    return out;
  };

  const char* jobs_env = std::getenv("OWLCAL_MC_JOBS");
  const int jobs = std::clamp(jobs_env ? std::atoi(jobs_env) : 2, 1, num_robots);
  std::vector<RobotRun> runs(num_robots);
  std::vector<bool> done(num_robots, false);
  std::mutex mutex;
  std::condition_variable finished;
  std::atomic<int> next{0};
  std::vector<std::thread> workers;
  for (int j = 0; j < jobs; ++j)
    workers.emplace_back([&] {
      for (int i; (i = next++) < num_robots;) {
        RobotRun r;
        try {
          r = run_robot(i);
        } catch (const std::exception& e) {
          r.name = "robot " + std::to_string(i);
          r.failure = r.name + ": " + e.what();
          r.line = r.failure + "\n";
        }
        std::lock_guard<std::mutex> lock(mutex);
        runs[i] = std::move(r);
        done[i] = true;
        finished.notify_all();
      }
    });
  fitting::SigmaCoverage coverage;
  for (int i = 0; i < num_robots; ++i) {
    {
      std::unique_lock<std::mutex> lock(mutex);
      finished.wait(lock, [&] { return bool(done[i]); });
    }
    const RobotRun& r = runs[i];
    coverage.SetLabel(r.name);
    if (!r.failure.empty())
      coverage.AddFailure(r.failure);
    else
      coverage.Add(r.parameters);
    std::fputs(r.line.c_str(), stdout);
    std::fflush(stdout);
  }
  for (auto& w : workers) w.join();
  std::printf("\n== robot_prior_mc_bench: %d %s (seeds %llu..%llu), protocols", num_robots,
              shipped ? "runs of the shipped robots" : "robots from the prior", (unsigned long long)first_seed,
              (unsigned long long)(first_seed + (shipped ? per_robot : num_robots) - 1));
  for (const auto& p : protocols) std::printf(" %s", p.c_str());
  std::printf(" ==\n%s\n", coverage.GroupTable().c_str());
  std::printf("overall: %d scored, %.1f %% within 1 sigma, %.2f %% within 3 sigma, %d failed runs\n", coverage.num_scored(),
              100 * coverage.FractionWithin(1), 100 * coverage.FractionWithin(3), coverage.num_failures());
  if (std::getenv("OWLCAL_MC_PER_PARAMETER")) std::printf("\n%s", coverage.Report().c_str());
  return 0;
}
