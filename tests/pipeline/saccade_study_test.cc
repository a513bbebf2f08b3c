// The calibrated-map saccade end to end on the in-process virtual Owl: the
// standard saccade protocol recorded with a calibration, read back as calibrate reads it, and
// evaluated against the physical bound (slew time for 10 deg + stream latency + one frame, from
// the robot's truth: data/sim/owl_default_truth.yaml Rx 380 deg/s, 100 ms, 30 fps = 159.6 ms).
#include "pipeline/saccade_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "fitting/ploop_analysis.h"
#include "owlcal_version.h"
#include "protocols/dataset_tables.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/robot_truth.h"
#include "sim/scene.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace saccade_study_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_saccade_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

sim::RobotTruth Truth(const std::string& file) {
  return file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/" + file);
}

// What calibrate gives the controller, here from the truth: the true head, each servo's slew and
// lag in pulse units, the stream latency and the servo's resolution. `scale_error` makes the
// map's deg/us wrong by that fraction (a calibration's error).
protocols::CalibratedMaps FromTruth(const sim::RobotTruth& t, double scale_error = 0) {
  protocols::CalibratedMaps c;
  c.head = t.HeadModel();
  c.source = "test: the robot's truth";
  for (int i = 0; i < models::kNumServos; ++i) {
    c.head.servo_params[i][1] *= 1 + scale_error;
    c.slew_us_per_s[i] = t.servos[i].slew_deg_per_s / t.servos[i].deg_per_us;
    c.lag_s[i] = t.servos[i].lag_s;
    c.resolution_us[i] = std::max<double>(t.servos[i].quantum_us, t.servos[i].dead_band_us);
    c.pwm_step_us[i] = t.servos[i].quantum_us;
  }
  c.exposure_delay_s = t.stream.latency_ms / 1000;
  return c;
}

struct Recorded {
  std::string dir;
  protocols::RunSummary summary;
  evaluation::CalibrationRun run;
};

// The standard saccade protocol (or `protocol_yaml`) on a robot, evaluated with the truth's bound.
Recorded RecordSaccades(const std::string& name,
                        const sim::RobotTruth& truth,
                        const std::optional<protocols::CalibratedMaps>& calibration,
                        const std::string& protocol_yaml = "",
                        bool plain_wall = false) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 5;
  if (plain_wall) {
    // No wall texture: nothing disc-like to lock onto when the disc is out of view.
    vo.scene = sim::DefaultScene();
    vo.scene->background.contrast = 0;
  }
  sim::VirtualOwl owl(vo);
  const protocols::Protocol p = protocol_yaml.empty()
                                    ? protocols::LoadProtocolFile(protocols::ResolveProtocolPath("saccade"))
                                    : protocols::ParseProtocolYaml(protocol_yaml, "test.yaml");
  protocols::RunOptions ro;
  Recorded r;
  r.dir = TempDir(name);
  ro.out_dir = r.dir;
  ro.robot_spec = "sim";
  ro.calibration = calibration;
  r.summary = protocols::RunProtocols({p}, owl, ro);
  CalibratePipelineOptions o;
  o.config = owl.Config();
  for (int i = 0; i < models::kNumServos; ++i) o.truth_slew_deg_per_s[i] = truth.servos[i].slew_deg_per_s;
  o.truth_latency_s = truth.stream.latency_ms / 1000;
  o.fps = truth.stream.fps;
  r.run.config = owl.Config();
  AddSaccadeEvaluation(r.dir, o, &r.run);
  for (const auto& row : protocols::ReadStepTrialsCsv(r.dir))
    std::cout << "trial " << row.trial << ": " << (row.status ? calib::TrialStatusName(*row.status) : "?") << " "
              << row.reason << " | " << row.message << "\n";
  for (const auto& s : r.run.steps)
    std::cout << "  settling " << s.info.settling_time << " s, settled " << s.info.settled << "\n";
  return r;
}

TEST(Saccade, DefaultRobotSettlesWithin1p3TimesThePhysicalBound) {
  const sim::RobotTruth t = Truth("");
  const Recorded r = RecordSaccades("default", t, FromTruth(t));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_TRUE(r.run.saccade);
  const evaluation::SaccadeEvaluation& ev = *r.run.saccade;
  EXPECT_NEAR(ev.bound_s, 10.0 / 380 + 0.100 + 1.0 / 30, 1e-9);
  EXPECT_EQ(ev.num_trials, 3);
  EXPECT_EQ(ev.num_ok, 3);
  EXPECT_EQ(ev.num_settled, 3);
  EXPECT_LE(ev.ratio_to_bound, 1.3) << "median " << ev.median_s << " s, bound " << ev.bound_s << " s";
  EXPECT_LE(ev.hi_s, 1.3 * ev.bound_s);
  // Not faster than physics either: no frame can show the joint arrived before the bound's slew
  // and latency have passed.
  EXPECT_GE(ev.lo_s, 10.0 / 380 + 0.100 - 1e-9);
}

// Cheap, slow servos on a slow stream (tests/data/robots/owl_slow_servos_truth.yaml: Rx 200 deg/s,
// 90 ms lag, 6 us backlash band; 15 fps, 200 ms latency): the controller acts only on frames
// received after the move's time plus the latency, also after the step away, and a trial runs on
// until its last correction has been seen, so the saccades settle (the issue saw 0 of 3: "target
// still 10 px off after 2 moves").
TEST(Saccade, SlowServosOnASlowStreamSettle) {
  const sim::RobotTruth t = Truth("tests/data/robots/owl_slow_servos_truth.yaml");
  const Recorded r = RecordSaccades("slow", t, FromTruth(t));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_TRUE(r.run.saccade);
  const evaluation::SaccadeEvaluation& ev = *r.run.saccade;
  EXPECT_EQ(ev.num_trials, 3);
  EXPECT_EQ(ev.num_ok, 3);
  EXPECT_GE(ev.num_settled, 2);
  std::cout << "slow: median " << ev.median_s << " s, bound " << ev.bound_s << " s, ratio " << ev.ratio_to_bound
            << "\n";
}

// The same robot with the motion calibrate fits on it (lag 51.5 ms, exposure delay 247 ms, the
// slew at its 300 deg/s prior): the joint's last degree arrives after the trial's frames, and the trial
// goes on until it has, then corrects (calibrate saw 0 of 3 settled: "target still 4.35 px off
// after 1 moves", the trial cut off while the target was still arriving).
TEST(Saccade, SlowServosSettleWithTheLagCalibrateFits) {
  const sim::RobotTruth t = Truth("tests/data/robots/owl_slow_servos_truth.yaml");
  protocols::CalibratedMaps c = FromTruth(t);
  for (int i = 0; i < models::kNumServos; ++i) {
    c.lag_s[i] = 0.0515;
    c.slew_us_per_s[i] = 300 / t.servos[i].deg_per_us;
  }
  c.exposure_delay_s = 0.247;
  const Recorded r = RecordSaccades("slow_fitted_lag", t, c);
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_TRUE(r.run.saccade);
  EXPECT_EQ(r.run.saccade->num_ok, 3);
  EXPECT_GE(r.run.saccade->num_settled, 2);
}

// A calibration 2 % off in scale still lands within a pixel or two and the correction finishes
// the job: every trial ok and settled.
TEST(Saccade, ScaleErrorOfTheMapIsCorrected) {
  const sim::RobotTruth t = Truth("");
  const Recorded r = RecordSaccades("scale", t, FromTruth(t, 0.02));
  ASSERT_TRUE(r.run.saccade);
  EXPECT_EQ(r.run.saccade->num_ok, 3);
  for (const auto& row : protocols::ReadStepTrialsCsv(r.dir)) {
    ASSERT_TRUE(row.final_offset_px);
    EXPECT_LT(std::abs(*row.final_offset_px), 1.5) << row.message;
  }
}

// The motion calibrate fits from the step frames can be faster than the servo (the default
// robot's: slew 489 deg/s for its 380, exposure delay 96.6 ms for 100): the controller then
// stops waiting while the joint is still arriving. A correction computed on such a frame
// overshoots (a default calibrate run ended a trial 6.1 px off after a 9 us correction taken
// 5.4 px before arrival); the controller corrects only once the target has stopped moving, so
// every trial is ok and ends within the dead zone.
TEST(Saccade, ATooFastMotionFitDoesNotCorrectWhileTheJointIsStillArriving) {
  const sim::RobotTruth t = Truth("");
  protocols::CalibratedMaps c = FromTruth(t);
  for (int i = 0; i < models::kNumServos; ++i) c.slew_us_per_s[i] *= 489.1 / 380;
  c.exposure_delay_s = 0.0966;
  const Recorded r = RecordSaccades("fastfit", t, c);
  ASSERT_TRUE(r.run.saccade);
  EXPECT_EQ(r.run.saccade->num_ok, 3);
  for (const auto& row : protocols::ReadStepTrialsCsv(r.dir)) {
    ASSERT_TRUE(row.final_offset_px);
    EXPECT_LT(std::abs(*row.final_offset_px), 1.0) << row.message;
  }
}

// 5 us PWM steps and 2-5 us dead bands: every trial runs, is a row with a status, and the
// controller neither cycles nor gives up early: final offsets within the servo's resolution.
void ExpectRunsOn(const std::string& file) {
  const sim::RobotTruth t = Truth(file);
  const Recorded r = RecordSaccades(fs::path(file).stem().string(), t, FromTruth(t));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  const auto rows = protocols::ReadStepTrialsCsv(r.dir);
  ASSERT_EQ(rows.size(), 3u);
  const double px_per_us = 587 * std::tan(t.servos[models::kRx].deg_per_us * M_PI / 180);
  const double res_px =
      std::max<double>(t.servos[models::kRx].quantum_us, t.servos[models::kRx].dead_band_us) * px_per_us;
  int ok = 0;
  for (const auto& row : rows) {
    ASSERT_TRUE(row.status);
    ok += *row.status == calib::TrialStatus::kOk;
    if (row.final_offset_px) {
      EXPECT_LT(std::abs(*row.final_offset_px), res_px) << row.message;
    }
  }
  EXPECT_GE(ok, 2) << file;
}

// A 5 us servo with backlash (tests/data/robots/owl_reassembled_c_truth.yaml, Rx: one pulse step
// is about 7 px) and a map 2 % off in scale: every trial is ok and, evaluated with the measured
// PWM step as calibrate evaluates it, at least 2 of 3 settle (within 2 % of the step, or within
// half a pulse step plus the image noise when that is wider).
TEST(Saccade, AFiveMicrosecondServoSettlesOnItsGrid) {
  const sim::RobotTruth t = Truth("tests/data/robots/owl_reassembled_c_truth.yaml");
  const Recorded r = RecordSaccades("grid5", t, FromTruth(t, 0.02));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  const auto rows = protocols::ReadStepTrialsCsv(r.dir);
  ASSERT_EQ(rows.size(), 3u);
  for (const auto& row : rows) {
    ASSERT_TRUE(row.status);
    EXPECT_EQ(*row.status, calib::TrialStatus::kOk) << row.reason << " | " << row.message;
  }
  // Evaluated as calibrate evaluates it, with the PWM step and dead band it measured.
  evaluation::CalibrationRun run;
  run.config = r.run.config;
  run.result.head = t.HeadModel();
  fitting::ServoResolutionResult res;
  res.servo = models::kRx;
  res.fit.ok = res.fit.determined = true;
  res.fit.resolution.step_us = t.servos[models::kRx].quantum_us;
  res.fit.resolution.dead_band_us = int(t.servos[models::kRx].dead_band_us);
  run.resolution.push_back(res);
  CalibratePipelineOptions o;
  o.config = run.config;
  for (int i = 0; i < models::kNumServos; ++i) o.truth_slew_deg_per_s[i] = t.servos[i].slew_deg_per_s;
  o.truth_latency_s = t.stream.latency_ms / 1000;
  o.fps = t.stream.fps;
  AddSaccadeEvaluation(r.dir, o, &run);
  ASSERT_TRUE(run.saccade);
  EXPECT_GE(run.saccade->num_settled, 2);
}

TEST(Saccade, RunsOnFiveMicrosecondSteps) { ExpectRunsOn("tests/data/robots/owl_step5_truth.yaml"); }
TEST(Saccade, RunsOnDeadBands) { ExpectRunsOn("tests/data/robots/owl_deadband_truth.yaml"); }

// No target in view (and a plain wall): every trial is a row "skipped" naming the lost target, and the evaluation
// counts 0 ok of 3 and names them.
TEST(Saccade, LostTargetIsARowNotASilentGap) {
  const sim::RobotTruth t = Truth("");
  const std::string yaml = R"(name: saccade
target: fixation
steps:
  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}
  - place-target: {target: fixation, distance_m: 1.0, offset_m: [3.0, 0]}
  - saccade: {trials: 3, frames: 12}
)";
  const Recorded r = RecordSaccades("lost", t, FromTruth(t), yaml, true);
  const auto rows = protocols::ReadStepTrialsCsv(r.dir);
  ASSERT_EQ(rows.size(), 3u);
  for (const auto& row : rows) {
    ASSERT_TRUE(row.status);
    EXPECT_EQ(*row.status, calib::TrialStatus::kSkipped);
    EXPECT_NE(row.reason.find("lost target"), std::string::npos) << row.reason;
  }
  ASSERT_TRUE(r.run.saccade);
  EXPECT_EQ(r.run.saccade->num_trials, 3);
  EXPECT_EQ(r.run.saccade->num_ok, 0);
  EXPECT_TRUE(std::isnan(r.run.saccade->median_s));
  int named = 0;
  for (const auto& n : r.run.saccade->notes) named += n.find("skipped") != std::string::npos;
  EXPECT_EQ(named, 3);
  EXPECT_EQ(r.run.result.warnings.size(), 3u);
}

}  // namespace saccade_study_test
}  // namespace owlcal::pipeline
