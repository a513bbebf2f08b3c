// Catch-up saccades end to end on the in-process virtual Owl: a disc moving at 10-30 deg/s is
// pursued by the eye (P loop on the map) with catch-up saccades; the retinal error measured from
// the frames is compared with the truth, and the saccades must reduce it. Robots: the default and
// data/sim variant A (slow servos with long lags, 133 ms latency, 2 % dropped frames).
#include "pipeline/catch_up_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/catch_up_study_page.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_catchup_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

sim::RobotTruth Truth(const std::string& file) {
  return file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/" + file);
}

// What a perfect calibrate gives: the truth's maps, and with `dynamics` the servos' slew and lag
// and the stream's exposure-to-arrival delay (calibrate fits them from its settling study).
protocols::CalibratedMaps FromTruth(const sim::RobotTruth& t, bool dynamics = false) {
  protocols::CalibratedMaps c;
  c.head = t.HeadModel();
  c.source = "test: the robot's truth";
  if (dynamics) {
    for (int i = 0; i < models::kNumServos; ++i) {
      c.slew_us_per_s[i] = t.servos[i].slew_deg_per_s / t.servos[i].deg_per_us;
      c.lag_s[i] = t.servos[i].lag_s;
    }
    c.exposure_delay_s = t.stream.latency_ms / 1000;
  }
  return c;
}

std::string Protocol(const std::string& cu =
                         "{eye: right, speeds_deg_per_s: [10, 30], duration_ms: 1500, "
                         "hold_ms: 300}") {
  return "name: catch-up-test\ntarget: fixation\nsteps:\n"
         "  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}\n"
         "  - place-target: {target: fixation, distance_m: 1.0}\n"
         "  - catch-up: " +
         cu + "\n";
}

struct Recorded {
  protocols::RunSummary summary;
  evaluation::CatchUpStudy study;
  std::string dir;
};

Recorded Record(const std::string& name,
                const sim::RobotTruth& truth,
                const std::string& protocol = Protocol(),
                bool dynamics = false,
                bool nominal = false) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 7;
  sim::VirtualOwl owl(vo);
  protocols::RunOptions ro;
  Recorded r;
  r.dir = TempDir(name);
  ro.out_dir = r.dir + "/dataset";
  ro.robot_spec = "sim";
  if (!nominal) ro.calibration = FromTruth(truth, dynamics);
  r.summary = protocols::RunProtocols({protocols::ParseProtocolYaml(protocol, "catch-up-test.yaml")}, owl, ro);
  r.study = EvaluateCatchUpDataset(ro.out_dir);
  for (const evaluation::CatchUpTrial& t : r.study.trials)
    std::cout << name << " " << t.speed_deg_per_s << " deg/s: " << t.status << " " << t.reason << "; " << t.saccades
              << " saccades, RMS " << t.rms_error_deg << " deg (true " << t.true_rms_error_deg << "), before "
              << t.mean_before_deg << " after " << t.mean_after_deg << ", response " << t.median_response_ms << " ms\n";
  return r;
}

// after_factor: the mean |error| in the first frame used after a catch-up saccade, as a fraction
// of the error that triggered it (default robot 3.5 -> 0.6 deg; variant A's slow, lagging servos
// with 5 us steps and 133 ms latency 4.2 -> 3.1 deg at 30 deg/s).
void ExpectPursuit(const Recorded& r, double after_factor) {
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  const evaluation::CatchUpStudy& s = r.study;
  ASSERT_TRUE(s.has_truth);
  ASSERT_EQ(s.num_trials, 2);
  EXPECT_EQ(s.num_ok, 2);
  const evaluation::CatchUpTrial& slow = s.trials[0];
  const evaluation::CatchUpTrial& fast = s.trials[1];
  // 30 deg/s outruns the P-loop pursuit: catch-up saccades, each reducing the error.
  EXPECT_GE(fast.saccades, 1);
  EXPECT_LE(slow.saccades, fast.saccades);
  EXPECT_LT(fast.mean_after_deg, after_factor * fast.mean_before_deg);
  for (const evaluation::CatchUpTrial& t : s.trials) {
    EXPECT_EQ(t.status, "ok") << t.reason;
    // The measured retinal error follows the truth (the lens model is the truth here).
    EXPECT_NEAR(t.rms_error_deg, t.true_rms_error_deg, 0.1 + 0.05 * t.true_rms_error_deg);
    EXPECT_LT(t.rms_error_deg, 10.0);
  }
}

TEST(CatchUp, DefaultRobotCatchUpSaccadesReduceTheRetinalError) {
  const Recorded r = Record("default", Truth(""));
  ExpectPursuit(r, 0.5);
  const std::string page = reports::WriteCatchUpStudy(r.study, r.dir + "/out", false);
  EXPECT_TRUE(fs::exists(page));
  for (const char* f : {"tables/catch_up_trials.csv",
                        "tables/catch_up_saccades.csv",
                        "tables/catch_up_frames.csv",
                        "figures/catch_up_trace.csv",
                        "catch_up.json"})
    EXPECT_TRUE(fs::exists(r.dir + "/out/" + f)) << f;
}

// The robot file's nominal maps, the standard protocol's speeds: the 30 deg/s trial's fixation
// used to take the image's darker corner for the disc (the whole-image search at every fixation
// move) and pursue it, a 16 deg median error reported ok; the first look's check and search keep
// the disc. 1.8 s: at 30 deg/s for 2 s the right eye ends within 20 us of Rx's limit and the
// trial stops there (the geometry of December 2026 moved the camera 1.2 mm outward).
TEST(CatchUp, DefaultRobotNominalMapsKeepTheDiscAtThirtyDegPerS) {
  const Recorded r = Record("default_nominal",
                            Truth(""),
                            Protocol("{eye: right, speeds_deg_per_s: [10, 20, 30], duration_ms: 1800, hold_ms: 500}"),
                            false,
                            true);
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_EQ(r.study.num_trials, 3);
  for (const evaluation::CatchUpTrial& t : r.study.trials) {
    EXPECT_EQ(t.status, "ok") << t.speed_deg_per_s << " deg/s: " << t.reason;
    EXPECT_EQ(t.found, t.frames);
    EXPECT_NEAR(t.rms_error_deg, t.true_rms_error_deg, 0.1 + 0.05 * t.true_rms_error_deg);
  }
  EXPECT_GE(r.study.trials[2].saccades, 1);
  EXPECT_LT(r.study.trials[2].mean_after_deg, 0.5 * r.study.trials[2].mean_before_deg);
}

TEST(CatchUp, VariantA) { ExpectPursuit(Record("variant_a", Truth("data/sim/owl_variant_a_truth.yaml")), 0.9); }

// With the servos' slew and lag and the stream's delay known (as calibrate measures them) the
// saccades lead the target by the right time: 3.7 -> 1.0 deg at 30 deg/s (without them, above:
// the default 133 ms and 300 deg/s, 3.9 -> 2.7 deg).
TEST(CatchUp, VariantAWithDynamics) {
  ExpectPursuit(Record("variant_a_dyn", Truth("data/sim/owl_variant_a_truth.yaml"), Protocol(), true), 0.5);
}

// An induced loss: 700 ms into the trial the disc is turned behind the robot. The fixation
// detector then finds wall blobs and the image's darker corners; the step must reject them by the
// disc's look (its first look's patch, NCC) and stop the trial as lost, from the images alone: the
// trial row is written by the step, which never reads the truth.
TEST(CatchUp, VariantAInducedLossIsReportedLostFromTheImages) {
  const Recorded r = Record("variant_a_loss",
                            Truth("data/sim/owl_variant_a_truth.yaml"),
                            Protocol("{eye: right, speeds_deg_per_s: [30], duration_ms: 1500, hold_ms: 300, "
                                     "hide_after_ms: 700}"),
                            true);
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_EQ(r.study.trials.size(), 1u);
  const evaluation::CatchUpTrial& t = r.study.trials[0];
  EXPECT_EQ(t.status, "lost target");
  EXPECT_NE(t.reason.find("consecutive frames"), std::string::npos) << t.reason;
  // Held until the hide, then nothing taken for it (the virtual Owl renders a frame with the scene
  // in force when it is grabbed: the first frame after the hide no longer shows the disc).
  int before = 0, found_before = 0, after = 0, found_after = 0;
  for (const evaluation::CatchUpFrame& f : r.study.frames) {
    if (f.t_s < 0.7) {
      ++before;
      found_before += f.found;
    } else if (f.t_s > 0.72) {
      ++after;
      found_after += f.found;
    }
  }
  EXPECT_GE(before, 20);
  EXPECT_EQ(found_before, before);
  EXPECT_EQ(after, 5);
  EXPECT_EQ(found_after, 0);
  EXPECT_LT(r.study.frames.size(), 30u);  // stopped after 5 lost frames, not run to the end (54 frames)
}

TEST(CatchUp, TrialsStoppedBeforeALimitOrWithoutFixationAreRowsWithTheirStatus) {
  // Rx's upper limit 9 deg right of its centre: the rightward sweep stops before the margin (not
  // settled); the leftward one cannot even fixate its start, 22 deg to the right (skipped).
  sim::RobotTruth t = Truth("");
  t.robot.servos[models::kRx].max_us = 1650;
  const Recorded r = Record("limit", t, Protocol("{eye: right, speeds_deg_per_s: [30, 30], duration_ms: 1500}"));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_EQ(r.study.num_trials, 2);
  EXPECT_EQ(r.study.trials[0].status, "not settled");
  EXPECT_NE(r.study.trials[0].reason.find("stopped before sending"), std::string::npos) << r.study.trials[0].reason;
  EXPECT_GT(r.study.trials[0].frames, 5);
  EXPECT_EQ(r.study.trials[1].status, "skipped");
  EXPECT_NE(r.study.trials[1].reason.find("no fixation"), std::string::npos) << r.study.trials[1].reason;
  EXPECT_EQ(r.study.num_ok, 0);
  EXPECT_EQ(r.study.notes.size(), 2u);
}

}  // namespace
}  // namespace owlcal::pipeline

// A trial whose measured retinal error leaves the truth tracked something else (on the default
// robot's nominal maps the 30 deg/s trial held a wall blob at the image centre, 16 deg median
// from the disc, and was reported ok): it is an "off target" row, not a pursuit.
TEST(CatchUp, ATrialThatTrackedSomethingElseIsOffTarget) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("owlcal_catch_up_off_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  {
    std::ofstream t(dir / "catch_up_trials.csv");
    t << "step_index,trial,speed_deg_per_s,direction,frames,found,saccades,map,status,reason\n"
      << "2,0,10.000,1,20,20,0,nominal map,ok,\n"
      << "2,1,30.000,1,20,20,0,nominal map,ok,\n";
    std::ofstream f(dir / "catch_up.csv");
    f << "step_index,trial,speed_deg_per_s,direction,k,t_s,target_az_deg,cmd_us,found,x_px,error_deg,true_error_deg,"
         "action\n";
    for (int trial = 0; trial < 2; ++trial)
      for (int k = 0; k < 20; ++k) {
        const double truth = trial == 0 ? 0.3 : -20 + 1.5 * k;  // trial 1: the target moves on, unseen
        f << "2," << trial << "," << (trial ? 30 : 10) << ",1," << k << "," << k / 30.0 << "," << -10 + k << ",1500,1,"
          << "320,0.1," << truth << ",pursuit\n";
      }
  }
  const owlcal::evaluation::CatchUpStudy s = owlcal::pipeline::EvaluateCatchUpDataset(dir.string());
  std::filesystem::remove_all(dir);
  ASSERT_EQ(s.trials.size(), 2u);
  EXPECT_EQ(s.trials[0].status, "ok");
  EXPECT_EQ(s.trials[1].status, "off target");
  EXPECT_NE(s.trials[1].reason.find("tracked something else"), std::string::npos) << s.trials[1].reason;
  EXPECT_EQ(s.num_ok, 1);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.back().find("off target"), std::string::npos);
}
