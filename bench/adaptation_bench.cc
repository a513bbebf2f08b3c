// Calibrate on robots whose robot file does not describe them (a student's reassembled robot:
// a reversed horn, centres off, stops inside the limits; cheap slow servos on a slow stream):
// runs pipeline::Calibrate (what `owlcal calibrate` runs) on the virtual Owl with each robot-truth
// file and the robot file in it, and prints the acceptance table of issue 34 per robot:
//   protocols   manifests complete of protocols run
//   map RMS     worst servo map's RMS error from the truth over the range the run used [deg]
//               (evaluation::ServoMapErrorOverRange, in the fit's gauge), and which servo
//   rest        the same without the pan zero (the pans' common offset, fitting/head_gauge.h)
//   pan zero    the pans' common offset's error and its reported sigma [deg]
//   ranged      fixations ranged of tried, and the ranging RMS error [%]
//   saccades    calibrated saccades settled of trials
//   slew        the loop model's slew over the truth's (or "prior": declared undetermined)
//   >5 sigma    parameters with a truth beyond 5 sigma, and the worst
//   file        the corrected robot file against the truth: directions, centres within 5 us,
//               limits inside the stops and within margin + 10 us of them (the neck's centre
//               is the fit's gauge and is not scored)
// and the bring-up's robot time. Each robot's datasets, results.json and evaluation.json stay
// under OUT/NAME (`owlcal report OUT/NAME` draws its report).
// Usage: adaptation_bench [OUT=/tmp/owlcal_adaptation] [ROBOT_TRUTH_FILE ...]
// (default: the reassembled and slow-servo robots of tests/data/robots)
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "evaluation/servo_map_eval.h"
#include "evaluation/truth_compare.h"
#include "owlcal_version.h"
#include "pipeline/bring_up.h"
#include "pipeline/calibrate.h"
#include "protocols/protocol.h"
#include "reports/report_data.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace fs = std::filesystem;
using namespace owlcal;

namespace {

constexpr int kMarginUs = 15;  // bring-up margin plus the search's stop error (pipeline/bring_up.h)

struct Row {
  std::string name;
  int complete = 0, protocols = 0;
  double worst_map_deg = 0;
  std::string worst_map_servo;
  double worst_rest_deg = 0;  // without the pan zero's common offset of the pans
  std::string worst_rest_servo;
  double pan_zero_error_deg = NAN, pan_zero_sigma_deg = NAN;
  int ranged = 0, fixations = 0;
  double ranging_rms_pct = NAN;
  int settled = 0, saccades = 0;
  std::string slew;
  int beyond5 = 0;
  std::string worst_param;
  std::vector<std::string> file_errors;
  double bring_up_s = 0, wall_s = 0;
};

Row RunRobot(const std::string& truth_file, const std::string& out_root) {
  Row row;
  const sim::RobotTruth truth = sim::LoadRobotTruth(truth_file);
  row.name = fs::path(truth_file).stem().string();
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 1;
  sim::VirtualOwl owl(vo);
  pipeline::CalibrateOptions co;
  co.out = out_root + "/" + row.name;
  fs::remove_all(co.out);
  co.truth = truth;
  co.robot.sim = {{"seed", 1}, {"truth_file", truth_file}};
  const auto t0 = std::chrono::steady_clock::now();
  const evaluation::CalibrationRun run = pipeline::Calibrate(owl, co);
  row.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  reports::WriteReportData(run, co.out);  // results.json and evaluation.json, for `owlcal report`

  for (const auto& [name, r] : run.settings["runs"].items()) {
    ++row.protocols;
    if (r.value("status", "") == "complete") ++row.complete;
  }
  if (run.result.head && run.truth) {
    std::array<evaluation::ServoMapError, models::kNumServos> e;
    for (int s = 0; s < models::kNumServos; ++s) {
      const models::ServoConfig& c = run.config.servos[s];
      e[s] = evaluation::ServoMapErrorOverRange(*run.result.head, *run.truth, s, c.min_us, c.max_us);
      if (e[s].rms_deg > row.worst_map_deg) {
        row.worst_map_deg = e[s].rms_deg;
        row.worst_map_servo = models::kServoNames[s];
      }
    }
    // The pan zero shifts both pan maps by one angle: its error is their mean errors' mean, and
    // each map's RMS without it is the rest of the map's error.
    row.pan_zero_error_deg = 0.5 * (e[models::kRx].mean_deg + e[models::kLx].mean_deg);
    const double pz = row.pan_zero_error_deg;
    for (int s = 0; s < models::kNumServos; ++s) {
      const bool pan = s == models::kRx || s == models::kLx;
      const double rest =
          pan ? std::sqrt(std::max(0.0, e[s].rms_deg * e[s].rms_deg - 2 * pz * e[s].mean_deg + pz * pz)) : e[s].rms_deg;
      if (rest > row.worst_rest_deg) {
        row.worst_rest_deg = rest;
        row.worst_rest_servo = models::kServoNames[s];
      }
    }
    const nlohmann::json& h = run.result.diagnostics.value("head", nlohmann::json::object());
    if (h.contains("pan_zero")) row.pan_zero_sigma_deg = h["pan_zero"].value("sigma_deg", NAN);
  }
  if (run.ranging) {
    row.fixations = int(run.ranging->rows.size());
    row.ranged = run.ranging->num_ok;
    row.ranging_rms_pct = 100 * run.ranging->rms_rel_error;
  }
  if (run.saccade) {
    row.saccades = run.saccade->num_trials;
    row.settled = run.saccade->num_settled;
  }
  const nlohmann::json& st = run.result.diagnostics.value("settling", nlohmann::json::object());
  if (st.value("slew_source", "") == "prior") {
    row.slew = "prior";
  } else if (st.contains("slew_deg_per_s") && st.contains("servo")) {
    const int s = std::max(0, protocols::ServoIndexFromName(st["servo"].get<std::string>()));
    char b[32];
    std::snprintf(b, sizeof b, "%.2fx", st["slew_deg_per_s"].get<double>() / truth.servos[s].slew_deg_per_s);
    row.slew = b;
  } else {
    row.slew = "none";
  }
  const evaluation::TruthComparison tc = evaluation::CompareWithTruth(run.result);
  double worst = 0;
  for (const auto& r : tc.rows)
    if (std::isfinite(r.z) && std::abs(r.z) > 5) {
      ++row.beyond5;
      if (std::abs(r.z) > worst) {
        worst = std::abs(r.z);
        char b[96];
        std::snprintf(b, sizeof b, "%s z=%.1f", r.name.c_str(), r.z);
        row.worst_param = b;
      }
    }
  std::vector<std::string> changes;
  const models::RobotConfig corrected = pipeline::CorrectedRobotFile(truth.robot, run.config, run.result, &changes);
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig& c = corrected.servos[s];
    const sim::ServoTruth& t = truth.servos[s];
    const std::string n = models::kServoNames[s];
    if (c.direction != t.direction) row.file_errors.push_back(n + " direction");
    if (s != models::kNeck && std::abs(c.centre_us - t.centre_us) > 5)
      row.file_errors.push_back(n + " centre " + std::to_string(c.centre_us) + " vs " +
                                std::to_string(int(t.centre_us)));
    const double lo = std::max<double>(t.endstop_lo_us, truth.robot.servos[s].min_us);
    const double hi = std::min<double>(t.endstop_hi_us, truth.robot.servos[s].max_us);
    if (c.min_us < lo || c.min_us > lo + kMarginUs + 10)
      row.file_errors.push_back(n + " min " + std::to_string(c.min_us));
    if (c.max_us > hi || c.max_us < hi - kMarginUs - 10)
      row.file_errors.push_back(n + " max " + std::to_string(c.max_us));
  }
  if (run.result.diagnostics.contains("bring_up"))
    row.bring_up_s = run.result.diagnostics["bring_up"].value("robot_time_s", 0.0);
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string out = argc > 1 ? argv[1] : (fs::temp_directory_path() / "owlcal_adaptation").string();
  std::vector<std::string> files;
  for (int i = 2; i < argc; ++i) files.push_back(argv[i]);
  if (files.empty())
    for (const char* f : {"owl_reassembled_truth.yaml", "owl_slow_servos_truth.yaml"})
      files.push_back(std::string(OWLCAL_SOURCE_DIR) + "/tests/data/robots/" + f);
  std::printf("adaptation bench at %s: pipeline::Calibrate (the standard suite) per robot, seed 1\n", OWLCAL_VERSION);
  std::printf("%-28s %-9s %-14s %-14s %-16s %-14s %-8s %-7s %-28s %-6s %s\n",
              "robot",
              "protocols",
              "map RMS [deg]",
              "rest [deg]",
              "pan zero (sigma)",
              "ranged (RMS)",
              "saccade",
              "slew",
              ">5 sigma (worst)",
              "bring",
              "corrected file");
  for (const std::string& f : files) {
    Row r;
    try {
      r = RunRobot(f, out);
    } catch (const std::exception& e) {
      std::printf("%-28s FAILED: %s\n", fs::path(f).stem().string().c_str(), e.what());
      continue;
    }
    std::string file = r.file_errors.empty() ? "agrees" : "";
    for (const auto& e : r.file_errors) file += (file.empty() ? "" : "; ") + e;
    char map[40], rest[40], pz[40], ranged[40], sacc[16], beyond[96], bring[16];
    std::snprintf(map, sizeof map, "%.3f %s", r.worst_map_deg, r.worst_map_servo.c_str());
    std::snprintf(rest, sizeof rest, "%.3f %s", r.worst_rest_deg, r.worst_rest_servo.c_str());
    std::snprintf(pz, sizeof pz, "%+.3f (%.3f)", r.pan_zero_error_deg, r.pan_zero_sigma_deg);
    std::snprintf(ranged, sizeof ranged, "%d/%d (%.2f %%)", r.ranged, r.fixations, r.ranging_rms_pct);
    std::snprintf(sacc, sizeof sacc, "%d/%d", r.settled, r.saccades);
    std::snprintf(beyond, sizeof beyond, "%d %s", r.beyond5, r.worst_param.c_str());
    std::snprintf(bring, sizeof bring, "%.0f s", r.bring_up_s);
    std::printf("%-28s %d/%-7d %-14s %-14s %-16s %-14s %-8s %-7s %-28s %-6s %s  [%.0f s wall]\n",
                r.name.c_str(),
                r.complete,
                r.protocols,
                map,
                rest,
                pz,
                ranged,
                sacc,
                r.slew.c_str(),
                beyond,
                bring,
                file.c_str(),
                r.wall_s);
    std::fflush(stdout);
  }
  std::printf(
      "acceptance: protocols all complete; map RMS <= 0.05 deg, or the rest <= 0.05 deg and the pan zero within 2 "
      "sigma (the report names it with its sigma); ranged >= 8/9 with RMS <= 1 %%; saccades "
      ">= 2/3; slew 0.5-2x or prior; none beyond 5 sigma; corrected file agrees\n");
  return 0;
}
