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

protocols::CalibratedMaps FromTruth(const sim::RobotTruth& t) {
  protocols::CalibratedMaps c;
  c.head = t.HeadModel();
  c.source = "test: the robot's truth";
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
  CatchUpStudy study;
  std::string dir;
};

Recorded Record(const std::string& name, const sim::RobotTruth& truth, const std::string& protocol = Protocol()) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 7;
  sim::VirtualOwl owl(vo);
  protocols::RunOptions ro;
  Recorded r;
  r.dir = TempDir(name);
  ro.out_dir = r.dir + "/dataset";
  ro.robot_spec = "sim";
  ro.calibration = FromTruth(truth);
  r.summary = protocols::RunProtocols({protocols::ParseProtocolYaml(protocol, "catch-up-test.yaml")}, owl, ro);
  r.study = EvaluateCatchUpDataset(ro.out_dir);
  for (const CatchUpTrial& t : r.study.trials)
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
  const CatchUpStudy& s = r.study;
  ASSERT_TRUE(s.has_truth);
  ASSERT_EQ(s.num_trials, 2);
  EXPECT_EQ(s.num_ok, 2);
  const CatchUpTrial& slow = s.trials[0];
  const CatchUpTrial& fast = s.trials[1];
  // 30 deg/s outruns the P-loop pursuit: catch-up saccades, each reducing the error.
  EXPECT_GE(fast.saccades, 1);
  EXPECT_LE(slow.saccades, fast.saccades);
  EXPECT_LT(fast.mean_after_deg, after_factor * fast.mean_before_deg);
  for (const CatchUpTrial& t : s.trials) {
    EXPECT_EQ(t.status, "ok") << t.reason;
    // The measured retinal error follows the truth (the lens model is the truth here).
    EXPECT_NEAR(t.rms_error_deg, t.true_rms_error_deg, 0.1 + 0.05 * t.true_rms_error_deg);
    EXPECT_LT(t.rms_error_deg, 10.0);
  }
}

TEST(CatchUp, DefaultRobotCatchUpSaccadesReduceTheRetinalError) {
  const Recorded r = Record("default", Truth(""));
  ExpectPursuit(r, 0.5);
  const std::string page = WriteCatchUpStudy(r.study, r.dir + "/out", false);
  EXPECT_TRUE(fs::exists(page));
  for (const char* f : {"tables/catch_up_trials.csv",
                        "tables/catch_up_saccades.csv",
                        "tables/catch_up_frames.csv",
                        "figures/catch_up_trace.csv",
                        "catch_up.json"})
    EXPECT_TRUE(fs::exists(r.dir + "/out/" + f)) << f;
}

TEST(CatchUp, VariantA) { ExpectPursuit(Record("variant_a", Truth("data/sim/owl_variant_a_truth.yaml")), 0.9); }

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
  const owlcal::pipeline::CatchUpStudy s = owlcal::pipeline::EvaluateCatchUpDataset(dir.string());
  std::filesystem::remove_all(dir);
  ASSERT_EQ(s.trials.size(), 2u);
  EXPECT_EQ(s.trials[0].status, "ok");
  EXPECT_EQ(s.trials[1].status, "off target");
  EXPECT_NE(s.trials[1].reason.find("tracked something else"), std::string::npos) << s.trials[1].reason;
  EXPECT_EQ(s.num_ok, 1);
  ASSERT_FALSE(s.notes.empty());
  EXPECT_NE(s.notes.back().find("off target"), std::string::npos);
}
