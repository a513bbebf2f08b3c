// Monte-Carlo check of owlcal's sigmas over robots drawn from the prior of real Owls
// (sim/robot_prior.h): each robot runs the whole calibration (pipeline::Calibrate, what `owlcal
// calibrate` runs, on the virtual Owl with that robot truth and board, the protocols that fit
// parameters: intrinsics, stereo, servo_sweep), and every fitted parameter with a truth is scored
// as z = (value - truth) / sigma.
// Prints one line per robot and the pooled coverage per parameter group (lens, stereo, servo
// maps, head geometry): target 68 +- 5 % within 1 sigma, >= 99 % within 3 sigma.
// Run it under `nice`: one robot is about 20 s of CPU with the standard protocols (16 s wall alone
// on 2 cores, measured on prior-1 at ac925cd: capture 7.7 s, lens-model choice 5.4 s, head fit
// 2.4 s); OWLCAL_MC_JOBS robots (default 2) run at once, so 30 robots take about 10 minutes on a
// quiet 2-core machine.
//
// Usage: robot_prior_mc_bench [num_robots=30] [first_seed=1] [protocol ...]
//        robot_prior_mc_bench reassembled [num_robots=30] [first_seed=1] [protocol ...]
//        robot_prior_mc_bench slow [num_robots=30] [first_seed=1] [protocol ...]
//        robot_prior_mc_bench shipped [seeds_per_robot=1] [first_seed=1] [protocol ...]
//        robot_prior_mc_bench shipped+rim [seeds_per_robot=1] [first_seed=1] [protocol ...]
// `reassembled` and `slow`: robots of the prior's other kinds (sim/robot_prior.h RobotKind: a
// reversed horn, centres and stops off the robot file's; slow servos, a slow stream, a wide
// rational lens), drawn from the same seeds as the prior's robots, which their robot file does
// not describe. Their default protocols start with `limits`, the bring-up
// (pipeline/bring_up.h): it learns the directions and the stops, and the later protocols run on
// what it learned; the scoring is the same.
// `shipped`: the three robots in data/sim (default, variant a, variant b) instead of drawn ones;
// `shipped+rim` adds tests/data/robots/owl_narrow_rim_truth.yaml (the rim hides the chessboard
// near the pan ends; the tag sheets carry the sweep there).
// When the sweep has tag sheets (the standard servo_sweep), calibrate fits the head twice, on the
// chessboard alone and fused with the tags (pipeline/tag_study.h), and writes both fits'
// parameters with the truth (diagnostics.tags.parameters): they are scored as their own groups,
// "servo maps (fused)", "head geometry (fused)", "lens (fused)" and the same "(chessboard)", and
// each servo map's error at both ends of its configured range (diagnostics.tags.servo_ends) as
// "servo ends (fused)" and "servo ends (chessboard)". The groups without a suffix are the
// calibration's result (its head is one of the two fits: CalibratePipelineOptions::fuse_tags).
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
#include <map>
#include <mutex>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "evaluation/servo_map_eval.h"
#include "evaluation/truth_compare.h"
#include "fitting/monte_carlo.h"
#include "fitting/result.h"
#include "owlcal_version.h"
#include "pipeline/calibrate.h"
#include "sim/robot_prior.h"
#include "sim/virtual_owl.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  using namespace owlcal;
  const bool with_rim = argc > 1 && std::string(argv[1]) == "shipped+rim";
  const bool shipped = argc > 1 && (std::string(argv[1]) == "shipped" || with_rim);
  sim::RobotKind kind = sim::RobotKind::kPrior;
  for (const sim::RobotKind k : {sim::RobotKind::kReassembled, sim::RobotKind::kSlow})
    if (argc > 1 && std::string(argv[1]) == sim::RobotKindName(k)) kind = k;
  const bool drawn_kind = kind != sim::RobotKind::kPrior;
  // Arguments before the robot count: the mode word, if any.
  const int mode_args = (shipped || drawn_kind) ? 1 : 0;
  const std::string kShipped[4] = {std::string(OWLCAL_SOURCE_DIR) + "/data/sim/owl_default_truth.yaml",
                                   std::string(OWLCAL_SOURCE_DIR) + "/data/sim/owl_variant_a_truth.yaml",
                                   std::string(OWLCAL_SOURCE_DIR) + "/data/sim/owl_variant_b_truth.yaml",
                                   std::string(OWLCAL_SOURCE_DIR) + "/tests/data/robots/owl_narrow_rim_truth.yaml"};
  const int num_shipped = with_rim ? 4 : 3;
  const int per_robot = shipped ? (argc > 2 ? std::atoi(argv[2]) : 1) : 1;
  const int num_robots =
      shipped ? num_shipped * per_robot : (argc > 1 + mode_args ? std::atoi(argv[1 + mode_args]) : 30);
  const uint64_t first_seed = argc > 2 + mode_args ? std::strtoull(argv[2 + mode_args], nullptr, 10) : 1;
  if (num_robots < 1) {
    std::fprintf(stderr, "robot_prior_mc_bench: need at least one robot\n");
    return 2;
  }
  std::vector<std::string> protocols;
  for (int i = 3 + mode_args; i < argc; ++i) protocols.push_back(argv[i]);
  // The other kinds' robot files are wrong about them: the bring-up first.
  if (protocols.empty() && drawn_kind) protocols = {"limits", "intrinsics", "stereo", "servo_sweep"};
  if (protocols.empty()) protocols = {"intrinsics", "stereo", "servo_sweep"};
  // The shipped robots' and each kind's runs in their own folder: a `shipped` run after a prior
  // run with the same first seed removed the prior robots' kept results.
  const std::string folder = shipped      ? "owlcal_shipped_mc_"
                             : drawn_kind ? "owlcal_" + std::string(sim::RobotKindName(kind)) + "_mc_"
                                          : "owlcal_prior_mc_";
  const fs::path root = fs::temp_directory_path() / (folder + std::to_string(first_seed));
  fs::remove_all(root);
  fs::create_directories(root);

  // One robot: draw it, calibrate it, score it. Robots are independent (each its own virtual Owl
  // and folder), so OWLCAL_MC_JOBS (default 2) of them run at once on threads; each robot's seed, files and result
  // depend only on its index, and the lines and the pooled table are made in robot order below, so the output does not
  // depend on the number of jobs.
  struct RobotRun {
    std::string name, line, failure;
    std::vector<fitting::Parameter> parameters;
    // The two head fits' parameters and their servo-map errors at the range ends, by fit
    // ("fused", "chessboard"); empty without tag sheets.
    std::map<std::string, std::vector<fitting::Parameter>> fit_parameters, fit_ends;
  };
  auto run_robot = [&](int i) {
    RobotRun out;
    const uint64_t seed = first_seed + uint64_t(shipped ? i % per_robot : i);
    std::mt19937_64 rng(seed * 7919 + 17);
    std::string name = std::string(sim::RobotKindName(kind)) + "-" + std::to_string(seed);
    sim::DrawnRobot robot = sim::DrawRobot(&rng, name, kind);
    if (shipped) {
      const std::string file = kShipped[i / per_robot];
      robot.truth = sim::LoadRobotTruth(file);
      robot.scene = sim::DefaultScene();
      const std::string base = fs::path(file).filename().string();
      name = base.substr(0, base.find("_truth")) + "-seed" + std::to_string(seed);
    }
    out.name = name;
    const fs::path dir = root / name;
    fs::create_directories(dir);
    sim::SaveRobotTruth(robot.truth, (dir / "truth.yaml").string());
    std::ofstream((dir / "scene.yaml").string()) << sim::SceneJson(robot.scene).dump(2);
    // The virtual Owl as `owlcal calibrate --robot-truth truth.yaml --scene scene.yaml --seed S`
    // builds it, calibrated by the same library call, in this process.
    sim::VirtualOwl owl(robot.OwlOptions(seed));
    pipeline::CalibrateOptions co;
    co.out = (dir / "cal").string();
    co.protocols = protocols;
    co.robot.sim = {
        {"seed", seed}, {"truth_file", (dir / "truth.yaml").string()}, {"scene_file", (dir / "scene.yaml").string()}};
    const evaluation::CalibrationRun run = pipeline::Calibrate(owl, co);
    const fitting::CalibrationResult& r = run.result;
    out.parameters = r.parameters;
    const nlohmann::json tags = r.diagnostics.value("tags", nlohmann::json::object());
    const nlohmann::json fits = tags.value("parameters", nlohmann::json::object());
    for (const auto& [fit, params] : fits.items())
      out.fit_parameters[fit] = fitting::ResultFromJson({{"parameters", params}}).parameters;
    const nlohmann::json ends = tags.value("servo_ends", nlohmann::json::array());
    for (const auto& e : ends) {
      for (const auto& [fit, key] :
           {std::pair<std::string, std::string>{"fused", "with_tags"}, {"chessboard", "without_tags"}}) {
        const nlohmann::json err = e.value("error_" + key + "_deg", nlohmann::json());
        const nlohmann::json sig = e.value("sigma_" + key + "_deg", nlohmann::json());
        if (!err.is_number() || !sig.is_number()) continue;
        fitting::Parameter p;
        p.name = "servo_end." + e.value("servo", std::string()) + "." + e.value("end", std::string());
        p.value = err.get<double>();
        p.sigma = sig.get<double>();
        p.unit = "deg";
        p.truth = 0.0;
        out.fit_ends[fit].push_back(p);
      }
    }
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
    // The worst servo map against the truth over the robot file's range (acceptance: 0.05 deg
    // RMS) and the fitted bow against the board's.
    double worst_map = NAN;
    std::string worst_servo;
    for (int s = 0; s < models::kNumServos && run.truth && r.head; ++s) {
      const fitting::Parameter* p = r.Find("servo." + std::string(models::kServoNames[s]) + ".deg_per_us");
      if (!p || !p->determined) continue;
      const models::ServoConfig& c = run.config.servos[s];
      const double rms = evaluation::ServoMapErrorOverRange(*r.head, *run.truth, s, c.min_us, c.max_us).rms_deg;
      if (!(rms <= worst_map)) worst_map = rms, worst_servo = models::kServoNames[s];
    }
    const fitting::Parameter* bow = r.Find("head.board_warp_x_mm");
    char buf[1024];
    std::snprintf(
        buf,
        sizeof buf,
        "%s: f %.0f/%.0f px, quantum %d us, dead band %.1f us, noise %.1f, jpeg %d, warp %.2f mm (fitted %.3f) | "
        "%d scored, RMS(z) %.2f, worst %s z = %+.2f | servo maps worst %.4f deg RMS (%s)\n",
        name.c_str(),
        t.intrinsics[0].params[0],
        t.intrinsics[1].params[0],
        t.servos[0].quantum_us,
        t.servos[0].dead_band_us,
        t.stream.noise_sigma,
        t.stream.jpeg_quality,
        1000 * robot.scene.Find("chessboard")->warp_m.x(),
        bow ? bow->value : NAN,
        n,
        n ? std::sqrt(sum / n) : NAN,
        worst_name.c_str(),
        worst,
        worst_map,
        worst_servo.c_str());
    out.line = buf;
    // Per head fit: RMS(z) and the worst |z| of its parameters, and the worst servo end.
    for (const char* fit : {"fused", "chessboard"}) {
      if (!out.fit_parameters.count(fit)) continue;
      double ss = 0, worst_z = 0, worst_end = 0;
      int m = 0;
      std::string wn, we;
      for (const auto& p : out.fit_parameters[fit]) {
        if (!p.determined || !p.truth || !(p.sigma > 0)) continue;
        const double z = (p.value - *p.truth) / p.sigma;
        ss += z * z;
        ++m;
        if (std::abs(z) > std::abs(worst_z)) worst_z = z, wn = p.name;
      }
      for (const auto& p : out.fit_ends[fit]) {
        const double z = p.value / p.sigma;
        if (std::abs(z) > std::abs(worst_end)) worst_end = z, we = p.name.substr(10);
      }
      std::snprintf(buf,
                    sizeof buf,
                    "    %s fit: RMS(z) %.2f, worst %s z = %+.2f | servo ends worst %s z = %+.2f\n",
                    fit,
                    m ? std::sqrt(ss / m) : NAN,
                    wn.c_str(),
                    worst_z,
                    we.c_str(),
                    worst_end);
      out.line += buf;
    }
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
    for (const auto& [fit, params] : r.fit_parameters) coverage.Add(params, " (" + fit + ")");
    for (const auto& [fit, ends] : r.fit_ends) coverage.Add(ends, " (" + fit + ")");
    std::fputs(r.line.c_str(), stdout);
    std::fflush(stdout);
  }
  for (auto& w : workers) w.join();
  const std::string population = shipped      ? "runs of the shipped robots"
                                 : drawn_kind ? std::string(sim::RobotKindName(kind)) + " robots from the prior"
                                              : "robots from the prior";
  std::printf("\n== robot_prior_mc_bench: %d %s (seeds %llu..%llu), protocols",
              num_robots,
              population.c_str(),
              (unsigned long long)first_seed,
              (unsigned long long)(first_seed + (shipped ? per_robot : num_robots) - 1));
  for (const auto& p : protocols) std::printf(" %s", p.c_str());
  std::printf(" ==\n%s\n", coverage.GroupTable().c_str());
  std::printf("overall: %d scored, %.1f %% within 1 sigma, %.2f %% within 3 sigma, %d failed runs\n",
              coverage.num_scored(),
              100 * coverage.FractionWithin(1),
              100 * coverage.FractionWithin(3),
              coverage.num_failures());
  if (std::getenv("OWLCAL_MC_PER_PARAMETER")) std::printf("\n%s", coverage.Report().c_str());
  return 0;
}
