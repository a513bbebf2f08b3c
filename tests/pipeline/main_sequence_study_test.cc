// The saccade main sequence end to end on the in-process virtual Owl: the main-sequence protocol
// recorded with the eye on a calibration (the robot's truth, what a perfect calibrate would give)
// or the robot file's nominal maps, evaluated from its frames and compared with the virtual Owl's
// servo truth. Acceptance (issue 16): the main-sequence slew within 5 % of the truth, on the
// default robot and on data/sim variant A (slow servos with long lags, 5 us PWM steps, 133 ms
// latency, 2 % dropped frames).
#include "pipeline/main_sequence_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/main_sequence_study_page.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace main_sequence_study_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_mainseq_" + name + "_" + std::to_string(::getpid()));
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

// Five amplitudes, three repeats (the standard protocol has six and four; each frame is rendered).
std::string Protocol(const std::string& ms =
                         "{eye: right, amplitudes_deg: [2, 5, 10, 20, 40], repeats: 3, "
                         "frames: 16, range_m: 1.0}") {
  return "name: main-sequence-test\ntarget: fixation\nsteps:\n"
         "  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}\n"
         "  - place-target: {target: fixation, distance_m: 1.0}\n"
         "  - main-sequence: " +
         ms + "\n";
}

struct Recorded {
  protocols::RunSummary summary;
  evaluation::MainSequenceStudy study;
  std::string dir;
};

Recorded Record(const std::string& name,
                const sim::RobotTruth& truth,
                const std::optional<protocols::CalibratedMaps>& cal,
                const std::string& protocol = Protocol()) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 5;
  sim::VirtualOwl owl(vo);
  protocols::RunOptions ro;
  Recorded r;
  r.dir = TempDir(name);
  ro.out_dir = r.dir + "/dataset";
  ro.robot_spec = "sim";
  ro.calibration = cal;
  r.summary = protocols::RunProtocols({protocols::ParseProtocolYaml(protocol, "main-sequence-test.yaml")}, owl, ro);
  r.study = EvaluateMainSequenceDataset(ro.out_dir);
  const fitting::MainSequenceFit& f = r.study.fit;
  std::cout << name << ": " << r.study.num_ok << " of " << r.study.num_saccades << " ok; truth slew "
            << r.study.true_slew_deg_per_s << " lag " << r.study.true_lag_s << "\n  pooled: " << f.motion.message
            << "\n  main sequence: " << f.peak.message << " (lag " << f.peak.lag_s << " +- " << f.peak.lag_sigma_s
            << ")\n  durations: " << f.duration.message << "\n  true angles: " << r.study.truth_fit.motion.message
            << "\n";
  for (const std::string& n : r.study.notes) std::cout << "  note: " << n << "\n";
  return r;
}

void ExpectMatchesTruth(const Recorded& r, int num_saccades) {
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  const evaluation::MainSequenceStudy& s = r.study;
  ASSERT_TRUE(s.has_truth);
  EXPECT_EQ(s.num_saccades, num_saccades);
  EXPECT_EQ(s.num_ok, num_saccades);
  const fitting::MainSequenceFit& f = s.fit;
  ASSERT_TRUE(f.motion.ok) << f.motion.message;
  ASSERT_TRUE(f.peak.ok) << f.peak.message;
  ASSERT_TRUE(f.duration.ok) << f.duration.message;
  const double ts = s.true_slew_deg_per_s, tl = s.true_lag_s;
  // The acceptance: the main sequence's slew within 5 % of the truth; the pooled and the duration
  // estimates too, each sigma honest (the truth within 3 sigma, no other allowance: the pooled
  // fit's residual-based sigma alone put the default robot's 381.9 deg/s 6.3 sigma off).
  EXPECT_NEAR(f.peak.vmax_deg_per_s, ts, 0.05 * ts);
  EXPECT_NEAR(f.motion.slew_deg_per_s, ts, 0.05 * ts);
  EXPECT_NEAR(f.duration.slew_deg_per_s, ts, 0.05 * ts);
  EXPECT_LT(std::abs(f.motion.slew_deg_per_s - ts), 3 * f.motion.slew_sigma_deg_per_s);
  EXPECT_LT(std::abs(f.peak.vmax_deg_per_s - ts), 3 * f.peak.vmax_sigma_deg_per_s);
  EXPECT_LT(std::abs(f.duration.slew_deg_per_s - ts), 3 * f.duration.slew_sigma_deg_per_s);
  // The statistical part alone (the jackknife over saccades) is several times the residual-based
  // one: the frames of one saccade share their errors.
  EXPECT_GT(f.motion.jackknife_slew_sigma_deg_per_s, f.motion.fit_slew_sigma_deg_per_s);
  // Not inflated beyond use: 5 % of the truth is 10 sigma or more.
  EXPECT_LT(f.motion.slew_sigma_deg_per_s, 0.005 * ts);
  EXPECT_NEAR(f.peak.lag_s, tl, 0.15 * tl);
  EXPECT_NEAR(f.motion.lag_s, tl, 0.15 * tl);
  for (const evaluation::MainSequenceSaccade& sa : s.saccades) {
    ASSERT_TRUE(sa.m.ok) << sa.saccade << ": " << sa.reason;
    // Measured amplitude against the true one, peak velocity against the truth's law.
    EXPECT_NEAR(sa.m.amplitude_deg, sa.true_amplitude_deg, 0.02 * sa.true_amplitude_deg + 0.05) << sa.saccade;
    EXPECT_NEAR(sa.m.peak_deg_per_s, sa.true_peak_deg_per_s, 0.08 * sa.true_peak_deg_per_s) << sa.saccade;
  }
}

TEST(MainSequence, DefaultRobotSlewWithinFivePercentOfTruth) {
  const sim::RobotTruth t = Truth("");
  const Recorded r = Record("default", t, FromTruth(t));
  ExpectMatchesTruth(r, 15);
  const std::string page = reports::WriteMainSequenceStudy(r.study, r.dir + "/out", false);
  EXPECT_TRUE(fs::exists(page));
  for (const char* f : {"tables/main_sequence_saccades.csv",
                        "tables/main_sequence_summary.csv",
                        "tables/main_sequence_frames.csv",
                        "figures/main_sequence_peak.csv",
                        "figures/main_sequence_duration.csv",
                        "figures/main_sequence_traces.csv",
                        "main_sequence.json"})
    EXPECT_TRUE(fs::exists(r.dir + "/out/" + f)) << f;
}

TEST(MainSequence, VariantASlewWithinFivePercentOfTruth) {
  const sim::RobotTruth t = Truth("data/sim/owl_variant_a_truth.yaml");
  const Recorded r = Record("variant_a", t, FromTruth(t));
  ExpectMatchesTruth(r, 15);
}

TEST(MainSequence, SaccadesPastTheLimitsAreSkippedRowsNeverSent) {
  // A 34 deg saccade of the left eye of a robot whose Lx range is cut to 350 us: refused at parse
  // when it cannot fit; here it fits the range but not around the fixation, so those saccades are
  // rows with status skipped and the reason, and the rest are measured.
  sim::RobotTruth t = Truth("");
  t.robot.servos[models::kLx].min_us = 1400;
  t.robot.servos[models::kLx].max_us = 1750;
  const Recorded r =
      Record("limits", t, FromTruth(t), Protocol("{eye: left, amplitudes_deg: [5, 10, 34], repeats: 2, frames: 14}"));
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  EXPECT_EQ(r.study.num_saccades, 6);
  int skipped = 0;
  for (const evaluation::MainSequenceSaccade& sa : r.study.saccades) {
    if (sa.amplitude_cmd_deg > 30) {
      EXPECT_EQ(sa.status, "skipped");
      EXPECT_NE(sa.reason.find("not sent"), std::string::npos) << sa.reason;
      ++skipped;
    } else {
      EXPECT_EQ(sa.status, "ok") << sa.reason;
    }
  }
  EXPECT_EQ(skipped, 2);
  EXPECT_EQ(r.study.num_ok, 4);
  EXPECT_GE(r.study.notes.size(), 2u);
}

}  // namespace main_sequence_study_test
}  // namespace owlcal::pipeline
