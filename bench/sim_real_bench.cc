// Sim-vs-real table: what real Owls do, measured on the course's real chessboard sets in
// data/owl-real/ (fitting/capture_stats.h), beside the virtual Owl taking the same kind of set
// (sim/handheld_capture.h: eyes centred, a held board, pairs saved as JPEG like the course's
// capture programs). Each statistic: the four real sets, their median, the virtual Owl's median
// over seeds, the ratio and a verdict: "ok" within a factor 1.5, else the reason.
// The virtual Owl is the DEFAULT robot and scene (sim::DefaultRobotTruth, sim::DefaultScene), or
// a robot-truth file as it is: the table judges what every command uses, not a preset.
// Servo rows come from the course notes and the real logs (no images show them): the real
// repeatability is the run-to-run spread of the eyes' vergence PWM at the same target distance in
// data/owl-real/noble2020-vergence-range (3 runs x 10 distances); the virtual one the spread of
// the joint angle when the servo returns to one pulse width from random earlier ones
// (sim/servo_dynamics.h, dead band + quantum + backlash, both directions).
//
// Usage: sim_real_bench [num_seeds=3] [robot_truth.yaml]
// The verdict counts include the servo rows.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "fitting/capture_stats.h"
#include "models/statistics.h"
#include "owlcal_version.h"
#include "sim/handheld_capture.h"
#include "sim/robot_truth.h"
#include "sim/servo_dynamics.h"
#include "sim/virtual_owl.h"

namespace {

using owlcal::fitting::CaptureStats;

// The median of the finite values (a row may lack a statistic); NaN when none is finite.
double Median(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  return owlcal::models::Median(std::move(v));
}

struct Row {
  std::string name;
  std::function<double(const CaptureStats&)> get;
  int digits;
  // Empty: judged by the factor 1.5. Otherwise why a larger difference is expected, or how
  // the row is judged instead (then `ok` decides).
  std::string note;
  std::function<bool(double real, double sim)> ok;
};

// Run-to-run spread of the vergence PWM (Lx - Rx) at the same target distance in the students'
// logs (columns run,actual_distance_cm,Rx_us,Lx_us,...): the pooled standard deviation [us] over
// distances and the number of distances. Throws naming the file when it cannot be read.
double RealVergenceSpreadUs(const std::string& path, int* num_distances) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::map<int, std::vector<double>> by_distance;
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::stringstream ss(line);
    std::string run, cm, rx, lx;
    if (!std::getline(ss, run, ',') || !std::getline(ss, cm, ',') || !std::getline(ss, rx, ',') ||
        !std::getline(ss, lx, ','))
      throw std::runtime_error(path + ": short row '" + line + "'");
    by_distance[std::stoi(cm)].push_back(std::stod(lx) - std::stod(rx));
  }
  double pooled = 0;
  int dof = 0;
  for (const auto& [cm, v] : by_distance) {
    if (v.size() < 2) continue;
    double mean = 0;
    for (double x : v) mean += x / v.size();
    for (double x : v) pooled += (x - mean) * (x - mean);
    dof += int(v.size()) - 1;
  }
  *num_distances = int(by_distance.size());
  return dof > 0 ? std::sqrt(pooled / dof) : NAN;
}

// The virtual servo returning to target_us from random earlier pulse widths (within +-150 us, each
// side equally often): the standard deviation of the joint angle [deg] a second later, and the
// mean difference between approaches from above and from below [deg] (the backlash).
void VirtualRepeatability(
    const owlcal::sim::ServoTruth& truth, int target_us, uint64_t seed, double* sd_deg, double* backlash_deg) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> away(3, 150);
  std::vector<double> angles;
  double sum_side[2] = {0, 0};
  int num_side[2] = {0, 0};
  for (int k = 0; k < 400; ++k) {
    const int side = k % 2;  // 0: from below, 1: from above
    const int before = target_us + (side ? away(rng) : -away(rng));
    owlcal::sim::ServoDynamics s(truth, before, 0);
    s.Command(target_us, 2'000'000'000);
    const double deg = s.AngleAt(3'000'000'000) * 180 / M_PI;
    angles.push_back(deg);
    sum_side[side] += deg;
    ++num_side[side];
  }
  double mean = 0, var = 0;
  for (double a : angles) mean += a / angles.size();
  for (double a : angles) var += (a - mean) * (a - mean) / (angles.size() - 1);
  *sd_deg = std::sqrt(var);
  *backlash_deg = std::abs(sum_side[1] / num_side[1] - sum_side[0] / num_side[0]);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace owlcal;
  const int num_seeds = argc > 1 ? std::max(1, std::atoi(argv[1])) : 3;
  const std::string data = OWLCAL_DATA_DIR;
  calib::TargetDefinition board;
  board.id = "owl-kit";
  board.cols = 9;
  board.rows = 6;
  board.square_m = 0.026;

  struct Set {
    std::string name, dir;
    bool mirror;
  };
  const std::vector<Set> sets = {
      {"kit2020", data + "/owl-real/kit2020-chessboard", false},
      {"darv-s1", data + "/owl-real/darvill2019-chessboard/session1", true},
      {"darv-s2", data + "/owl-real/darvill2019-chessboard/session2", true},
      {"darv-s3", data + "/owl-real/darvill2019-chessboard/session3", true},
  };
  std::vector<CaptureStats> real, virt;
  for (const Set& s : sets) {
    calib::ImagePairOptions po;
    po.mirror = s.mirror;
    real.push_back(fitting::MeasureCapture(s.name, s.dir, po, board));
    std::fprintf(stderr, "measured %s\n", s.name.c_str());
  }
  // The default robot and scene as every command gets them, or a robot-truth file as it is.
  const sim::RobotTruth truth = argc > 2 ? sim::LoadRobotTruth(argv[2]) : sim::DefaultRobotTruth();
  const sim::SceneDescription scene = sim::DefaultScene();
  for (int seed = 1; seed <= num_seeds; ++seed) {
    sim::VirtualOwlOptions vo;
    vo.seed = uint64_t(seed);
    vo.truth = truth;
    vo.scene = scene;
    sim::VirtualOwl owl(vo);
    const std::string dir =
        (std::filesystem::temp_directory_path() / ("owlcal_sim_real_" + std::to_string(seed))).string();
    std::filesystem::remove_all(dir);
    sim::HandHeldCaptureOptions ho;
    ho.seed = uint64_t(seed);
    sim::CaptureHandHeldSet(&owl, dir, ho);
    virt.push_back(fitting::MeasureCapture("virtual " + std::to_string(seed), dir, {}, board));
    std::filesystem::remove_all(dir);
    std::fprintf(stderr, "measured virtual seed %d\n", seed);
  }

  auto near_zero = [](double tol) { return [tol](double r, double s) { return std::abs(s - r) <= tol; }; };
  const std::vector<Row> rows = {
      {"boards detected [%]", [](const CaptureStats& s) { return 100 * s.DetectionRate(); }, 1, "", {}},
      {"per-view corner RMS, median [px]", [](const CaptureStats& s) { return s.view_rms_px.median; }, 3, "", {}},
      {"per-view corner RMS, 90th pct [px]", [](const CaptureStats& s) { return s.view_rms_px.p90; }, 3, "", {}},
      {"per-eye fit RMS [px]",
       [](const CaptureStats& s) { return 0.5 * (s.mono_rms_px[0] + s.mono_rms_px[1]); },
       3,
       "",
       {}},
      {"stereo fit RMS, joint [px]", [](const CaptureStats& s) { return s.stereo_rms_joint_px; }, 3, "", {}},
      {"stereo RMS / per-eye RMS", [](const CaptureStats& s) { return s.stereo_over_mono_rms; }, 2, "", {}},
      {"eye jitter, board centre [mm]", [](const CaptureStats& s) { return s.jitter_mm.median; }, 2, "", {}},
      {"eye jitter, rotation [deg]", [](const CaptureStats& s) { return s.jitter_deg.median; }, 3, "", {}},
      {"board warp along x [mm]", [](const CaptureStats& s) { return s.warp_mm[0]; }, 2, "", {}},
      {"board warp along y [mm]",
       [](const CaptureStats& s) { return s.warp_mm[1]; },
       2,
       "judged as |difference| <= 0.3 mm: both near zero",
       near_zero(0.3)},
      {"per-eye RMS with that warp [px]", [](const CaptureStats& s) { return s.warped_rms_px; }, 3, "", {}},
      {"noise on white squares [grey]", [](const CaptureStats& s) { return s.noise_white.median; }, 2, "", {}},
      {"noise on black squares [grey]", [](const CaptureStats& s) { return s.noise_black.median; }, 2, "", {}},
      {"edge blur sigma [px]", [](const CaptureStats& s) { return s.edge_sigma_px.median; }, 3, "", {}},
      {"white paper [grey]", [](const CaptureStats& s) { return s.white_level.median; }, 0, "", {}},
      {"black ink [grey]", [](const CaptureStats& s) { return s.black_level.median; }, 0, "", {}},
      {"saturated board pixels [%]",
       [](const CaptureStats& s) { return 100 * s.saturated_fraction; },
       2,
       "judged as |difference| <= 0.5 %: none in either",
       near_zero(0.5)},
      {"lens shading at the corner", [](const CaptureStats& s) { return s.lens_shading; }, 3, "", {}},
      {"lens shading, light gradient per image",
       [](const CaptureStats& s) { return s.lens_shading_curvature; },
       3,
       "the two estimates agree on the virtual Owl (its light is uniform) and differ 2x on every real set, "
       "so the room's light varies over a held board as much as the lens does and the images cannot part them; the "
       "real lens lies in 0.14-0.53 and the virtual Owl matches the first estimate",
       {}},
      {"JPEG blockiness", [](const CaptureStats& s) { return s.blockiness.median; }, 3, "", {}},
      {"JPEG quality of the files", [](const CaptureStats& s) { return double(s.jpeg_quality); }, 0, "", {}},
      {"board tilt, median [deg]", [](const CaptureStats& s) { return s.tilt_deg.median; }, 1, "", {}},
      {"board tilt, 90th pct [deg]", [](const CaptureStats& s) { return s.tilt_deg.p90; }, 1, "", {}},
      {"board distance, median [m]", [](const CaptureStats& s) { return s.distance_m.median; }, 2, "", {}},
      {"board share of the image", [](const CaptureStats& s) { return s.board_area.median; }, 3, "", {}},
  };

  std::printf("\n== sim_real_bench: real Owl sets vs the virtual Owl ('%s', %d hand-held sets of %d pairs) ==\n",
              truth.name.c_str(),
              num_seeds,
              sim::HandHeldCaptureOptions().num_pairs);
  std::printf("| statistic | %s | %s | %s | %s | real median | virtual | ratio | verdict |\n",
              real[0].name.c_str(),
              real[1].name.c_str(),
              real[2].name.c_str(),
              real[3].name.c_str());
  std::printf("|---|---|---|---|---|---|---|---|---|\n");
  int num_ok = 0, num_explained = 0, num_bad = 0;
  for (const Row& r : rows) {
    std::vector<double> rv, sv;
    for (const auto& s : real) rv.push_back(r.get(s));
    for (const auto& s : virt) sv.push_back(r.get(s));
    const double rm = Median(rv), sm = Median(sv);
    const double ratio = sm / rm;
    std::string verdict;
    if (r.ok) {
      const bool good = r.ok(rm, sm);
      verdict = (good ? "ok (" : "MISMATCH (") + r.note + ")";
      (good ? num_ok : num_bad)++;
    } else if (std::isfinite(ratio) && ratio >= 1 / 1.5 && ratio <= 1.5) {
      verdict = "ok";
      ++num_ok;
    } else if (!r.note.empty()) {
      verdict = "explained: " + r.note;
      ++num_explained;
    } else {
      verdict = "MISMATCH";
      ++num_bad;
    }
    std::printf("| %s |", r.name.c_str());
    for (double v : rv) std::printf(" %.*f |", r.digits, v);
    std::printf(" %.*f | %.*f | %.2f | %s |\n", r.digits, rm, r.digits, sm, ratio, verdict.c_str());
  }

  // Servos: from the course notes (guide), FACTS-level measurements on real logs, and the truth.
  const auto& rx = truth.servos[models::kRx];
  const auto& lx = truth.servos[models::kLx];
  // Servo rows count in the verdicts like the image rows: "ok...", "explained..." or "MISMATCH...".
  auto count = [&](const char* verdict) {
    const std::string v = verdict;
    (v.rfind("ok", 0) == 0 ? num_ok : v.rfind("explained", 0) == 0 ? num_explained : num_bad)++;
    return verdict;
  };
  std::printf("\n| servo statistic | real Owls | virtual Owl | verdict |\n|---|---|---|---|\n");
  std::printf("| eye dead band [us] | 1 (guide, MKS DS65K) | %.1f / %.1f (Rx / Lx) | %s |\n",
              rx.dead_band_us,
              lx.dead_band_us,
              count(std::abs(rx.dead_band_us - 1) <= 0.5 ? "ok" : "MISMATCH"));
  const double pan_scale = 0.5 * (rx.deg_per_us + lx.deg_per_us);
  std::printf(
      "| eye pan scale [deg/us] | 0.094 +- 0.007 (8 toe-in calibrations, two Owls); guide 0.113 | %.3f | %s |\n",
      pan_scale,
      count(pan_scale / 0.094 <= 1.5 && pan_scale / 0.094 >= 1 / 1.5 ? "ok" : "MISMATCH"));
  const double centre_off = 0.5 * (std::abs(rx.centre_us - truth.robot.servos[models::kRx].centre_us) +
                                   std::abs(lx.centre_us - truth.robot.servos[models::kLx].centre_us));
  std::printf("| pan centre vs robot file [us] | up to 60 (course code; noble2020: 1445/1430 vs 1545) | %.0f | %s |\n",
              centre_off,
              count(centre_off <= 60 ? "ok" : "MISMATCH"));
  // Repeatability and backlash: the students' three vergence runs against the virtual servos
  // returning to a vergence pose (each eye 30 us inwards of the robot file's centre).
  int num_distances = 0;
  const double real_spread_us =
      RealVergenceSpreadUs(data + "/owl-real/noble2020-vergence-range/vergence_runs.csv", &num_distances);
  constexpr double kNobleUsPerDeg = 10.73;  // the students' sheet
  const double real_spread_deg = real_spread_us / kNobleUsPerDeg;
  double sd[2], backlash[2];
  VirtualRepeatability(rx, truth.robot.servos[models::kRx].centre_us - 30, 11, &sd[0], &backlash[0]);
  VirtualRepeatability(lx, truth.robot.servos[models::kLx].centre_us + 30, 12, &sd[1], &backlash[1]);
  const double virt_spread_deg = std::hypot(sd[0], sd[1]);
  std::printf(
      "| vergence repeatability, SD of Lx - Rx at one target [deg] | %.2f (%.1f us at 10.73 us/deg; noble2020, 3 runs "
      "x %d "
      "distances) | %.2f (servos alone: SD %.2f / %.2f deg Rx / Lx, from random earlier pulses) | %s |\n",
      real_spread_deg,
      real_spread_us,
      num_distances,
      virt_spread_deg,
      sd[0],
      sd[1],
      count(virt_spread_deg / real_spread_deg >= 1 / 1.5 && virt_spread_deg / real_spread_deg <= 1.5
                ? "ok"
                : "explained: the real runs re-placed the target by hand and re-fixated it with a loop that stops "
                  "within its "
                  "tolerance at every distance; the servos' own share (dead band, PWM step, backlash) is the virtual "
                  "figure, "
                  "and fixation on the virtual Owl ends on a seated pulse (protocols/fixation)"));
  // A backlash b taken up from either side at random spreads one eye by b/2 (SD), two eyes by
  // b/sqrt(2): the real spread bounds the backlash from above.
  const double backlash_bound_deg = std::sqrt(2.0) * real_spread_deg;
  std::printf(
      "| backlash, approach from above minus below [deg] | <= %.2f (sqrt(2) x the vergence spread: no real log "
      "separates "
      "it; FACTS: ~1 deg scatter between toe-in sessions includes re-seating) | %.2f / %.2f (Rx / Lx; truth "
      "hysteresis %.1f / %.1f us) | %s |\n",
      backlash_bound_deg,
      backlash[0],
      backlash[1],
      rx.hysteresis_us,
      lx.hysteresis_us,
      count(std::max(backlash[0], backlash[1]) <= backlash_bound_deg ? "ok (within the bound)"
                                                                     : "MISMATCH (above the bound)"));
  std::printf("| PWM quantum [us] | 1, or 5 with pigpio's default sampling | %d | %s |\n",
              rx.quantum_us,
              count(rx.quantum_us == 1 || rx.quantum_us == 5 ? "ok (variant A has 5)" : "MISMATCH"));
  std::printf("| stream latency [ms] | 100-150 (FACTS: course P-loop analysis) | %.0f | %s |\n",
              truth.stream.latency_ms,
              count(truth.stream.latency_ms >= 100 / 1.5 && truth.stream.latency_ms <= 150 * 1.5 ? "ok" : "MISMATCH"));

  std::printf("\nverdicts: %d ok, %d explained, %d mismatches\n", num_ok, num_explained, num_bad);
  for (const auto& s : real)
    for (const auto& p : s.problems) std::printf("note (%s): %s\n", s.name.c_str(), p.c_str());
  for (const auto& s : virt)
    for (const auto& p : s.problems) std::printf("note (%s): %s\n", s.name.c_str(), p.c_str());
  return 0;
}
