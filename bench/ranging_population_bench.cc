// Vergence ranging over a population of robots built like real ones: robots drawn from the prior
// of real Owls (sim/robot_prior.h) with every eye servo's dead band redrawn in 1-5 us and the PWM
// step alternating 1 and 5 us between robots (odd seeds 5 us), each calibrated by pipeline::Calibrate
// (what `owlcal calibrate` runs) on the virtual Owl (limits with its resolution sweep, intrinsics, stereo,
// servo_sweep, vergence). Prints per robot the ranging RMS (acceptance: <= 1 %) and the pooled
// fraction of ranged fixations within 2 predicted sigma (acceptance: >= 90 %), and every
// fixation that was not ranged, with its reason.
// Run it under `nice -n 19`: one to four minutes of CPU per robot.
//
// Usage: ranging_population_bench [num_robots=6] [first_seed=1]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "calib/trial_status.h"
#include "pipeline/calibrate.h"
#include "sim/robot_prior.h"
#include "sim/virtual_owl.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  using namespace owlcal;
  const int num_robots = argc > 1 ? std::atoi(argv[1]) : 6;
  const uint64_t first_seed = argc > 2 ? std::strtoull(argv[2], nullptr, 10) : 1;
  if (num_robots < 1) {
    std::fprintf(stderr, "ranging_population_bench: need at least one robot\n");
    return 2;
  }
  const fs::path root = fs::temp_directory_path() / ("owlcal_ranging_population_" + std::to_string(first_seed));
  fs::remove_all(root);
  fs::create_directories(root);
  int pooled = 0, within = 0, failed_runs = 0, robots_over = 0;
  for (int i = 0; i < num_robots; ++i) {
    const uint64_t seed = first_seed + uint64_t(i);
    std::mt19937_64 rng(seed * 7919 + 17);
    const std::string name = "population-" + std::to_string(seed);
    sim::DrawnRobot robot = sim::DrawRobot(&rng, name);
    std::uniform_int_distribution<int> dead_band(1, 5);
    const int quantum = seed % 2 ? 5 : 1;
    std::string bands;
    for (int s = 0; s < models::kNumServos; ++s) {
      robot.truth.servos[s].quantum_us = quantum;
      if (s != models::kNeck) robot.truth.servos[s].dead_band_us = dead_band(rng);
      if (s) bands.push_back('/');
      bands.append(std::to_string(int(robot.truth.servos[s].dead_band_us)));
    }
    const fs::path dir = root / name;
    fs::create_directories(dir);
    sim::SaveRobotTruth(robot.truth, (dir / "truth.yaml").string());
    std::ofstream((dir / "scene.yaml").string()) << sim::SceneJson(robot.scene).dump(2);
    sim::VirtualOwl owl(robot.OwlOptions(seed));
    pipeline::CalibrateOptions co;
    co.out = (dir / "cal").string();
    co.protocols = {"limits", "intrinsics", "stereo", "servo_sweep", "vergence"};
    co.robot.sim = {
        {"seed", seed}, {"truth_file", (dir / "truth.yaml").string()}, {"scene_file", (dir / "scene.yaml").string()}};
    evaluation::CalibrationRun d;
    try {
      d = pipeline::Calibrate(owl, co);
    } catch (const std::exception& e) {
      ++failed_runs;
      std::printf("%s: FAILED (%s)\n", name.c_str(), e.what());
      continue;
    }
    if (!d.ranging) {
      ++failed_runs;
      std::printf("%s: no ranging evaluation\n", name.c_str());
      continue;
    }
    int n = 0, in = 0;
    for (const auto& row : d.ranging->rows) {
      if (!row.ok) {
        std::printf("  %s fixation %d (%.2f m) not ranged: %s: %s\n",
                    name.c_str(),
                    row.index,
                    row.true_m,
                    calib::TrialStatusName(row.status),
                    row.reason.c_str());
        continue;
      }
      ++n;
      in += std::abs(row.error_m) <= 2 * row.sigma_m;
    }
    pooled += n;
    within += in;
    robots_over += d.ranging->rms_rel_error > 0.01;
    std::string res;
    for (int s = 0; s < models::kNumServos; ++s) {
      const std::string p = std::string("servo.") + models::kServoNames[s] + ".";
      const fitting::Parameter* step = d.result.Find(p + "pwm_step_us");
      const fitting::Parameter* db = d.result.Find(p + "dead_band_us");
      if (step && db) {
        char b[96];
        std::snprintf(b, sizeof b, " %s %.0f/%.1f+-%.1f", models::kServoNames[s], step->value, db->value, db->sigma);
        res += b;
      }
    }
    std::printf(
        "%s: step %d us, dead bands %s us (Rx/Ry/Lx/Ly/Neck) | ranging %d ok of %zu, RMS %.3f %%, max %.3f %%, "
        "%d of %d within 2 sigma | measured step/dead band [us]:%s\n",
        name.c_str(),
        quantum,
        bands.c_str(),
        d.ranging->num_ok,
        d.ranging->rows.size(),
        100 * d.ranging->rms_rel_error,
        100 * d.ranging->max_abs_rel_error,
        in,
        n,
        res.c_str());
    std::fflush(stdout);
    fs::remove_all(dir / "cal" / "datasets");
  }
  std::printf("\n== ranging_population_bench: %d robots (seeds %llu..%llu) ==\n",
              num_robots,
              (unsigned long long)first_seed,
              (unsigned long long)(first_seed + num_robots - 1));
  std::printf("robots over 1 %% RMS: %d; pooled %d of %d ranged fixations within 2 sigma (%.1f %%); %d failed runs\n",
              robots_over,
              within,
              pooled,
              pooled ? 100.0 * within / pooled : NAN,
              failed_runs);
  return robots_over == 0 && failed_runs == 0 && pooled > 0 && within >= 0.9 * pooled ? 0 : 1;
}
