// The VOR end to end on the in-process virtual Owl: the vor protocol recorded with the eyes on a
// calibration (here the robot's truth, what a perfect calibrate would give) or on the robot file's
// nominal maps, evaluated from its frames and compared with the virtual Owl's true joint angles
// and true image slip. Robots: the default and data/sim variant A (a realistic robot: offsets,
// nonlinear servos, backlash, a neck of another scale).
#include "pipeline/vor_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "reports/vor_study_page.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::pipeline {
namespace vor_study_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_vor_" + name + "_" + std::to_string(::getpid()));
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

// Two sines and a step: the standard protocol's 0.5 and 1 Hz, fewer cycles.
// (Short: each frame is rendered, and the suite shares two cores.)
std::string VorProtocol(const std::string& vor =
                            "{sines_hz: [0.5, 1.0], amplitude_deg: 10, cycles: 1, "
                            "steps_deg: [8], hold_ms: 600, range_m: 1.0}") {
  return "name: vor-test\ntarget: fixation\nsteps:\n"
         "  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}\n"
         "  - place-target: {target: fixation, distance_m: 1.0}\n"
         "  - vor: " +
         vor + "\n";
}

struct Recorded {
  protocols::RunSummary summary;
  evaluation::VorStudy study;
  std::string dir;
};

Recorded Record(const std::string& name,
                const sim::RobotTruth& truth,
                const std::optional<protocols::CalibratedMaps>& cal,
                const std::string& protocol = VorProtocol()) {
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 3;
  sim::VirtualOwl owl(vo);
  protocols::RunOptions ro;
  Recorded r;
  r.dir = TempDir(name);
  ro.out_dir = r.dir + "/dataset";
  ro.robot_spec = "sim";
  ro.calibration = cal;
  r.summary = protocols::RunProtocols({protocols::ParseProtocolYaml(protocol, "vor-test.yaml")}, owl, ro);
  r.study = EvaluateVorDataset(ro.out_dir);
  for (const evaluation::VorTrialEye& t : r.study.results) {
    std::cout << name << " trial " << t.trial << " " << t.profile << " " << t.frequency_hz << " Hz " << t.condition
              << " " << models::kEyeNames[t.eye] << ": " << t.status << " " << t.reason << "; slip "
              << t.slip.rms_deg_per_s << " deg/s (true " << (t.true_slip ? t.true_slip->rms_deg_per_s : -1) << ")";
    if (t.condition == "vor")
      std::cout << "; gain " << t.gain.gain << " +- " << t.gain.gain_sigma << " lag " << t.gain.lag_deg << " deg, map "
                << t.map_gain.gain << ", truth " << (t.true_gain ? t.true_gain->gain : -1) << " lag "
                << (t.true_gain ? t.true_gain->lag_deg : -1);
    std::cout << "\n";
  }
  return r;
}

// What every run must show: all trials ok, the measured gain within 0.05 of the truth's, the
// phase lag within 3 deg of the truth's, the measured slip close to the true slip (0.3 deg/s, plus
// slip_scale of it: the nominal head's 585 px lens without distortion turns pixels into angles
// 1-2 % off on variant A's 578 px lens).
void ExpectMatchesTruth(const Recorded& r, int num_trials = 6, double slip_scale = 0) {
  ASSERT_EQ(r.summary.status, "complete") << r.summary.message;
  ASSERT_TRUE(r.study.has_truth);
  EXPECT_EQ(r.study.num_trials, num_trials);
  EXPECT_EQ(r.study.num_ok, num_trials);
  int gains = 0;
  for (const evaluation::VorTrialEye& t : r.study.results) {
    EXPECT_EQ(t.status, "ok") << t.reason;
    ASSERT_TRUE(t.true_slip);
    // The disc's detected position against its true pixel.
    EXPECT_NEAR(t.slip.rms_deg_per_s, t.true_slip->rms_deg_per_s, 0.3 + slip_scale * t.true_slip->rms_deg_per_s);
    if (t.condition != "vor") continue;
    ASSERT_TRUE(t.gain.ok) << t.gain.reason;
    ASSERT_TRUE(t.true_gain && t.true_gain->ok);
    EXPECT_NEAR(t.gain.gain, t.true_gain->gain, 0.05) << t.profile << " " << t.frequency_hz;
    EXPECT_GT(t.gain.gain_sigma, 0);
    if (t.profile == "sine") {
      EXPECT_NEAR(t.gain.lag_deg, t.true_gain->lag_deg, 3.0);
    }
    ++gains;
  }
  EXPECT_EQ(gains, num_trials);  // one per counter-rotating trial and eye
}

const evaluation::VorTrialEye* Find(const evaluation::VorStudy& s, const std::string& condition, double hz, int eye) {
  for (const evaluation::VorTrialEye& t : s.results)
    if (t.condition == condition && t.profile == "sine" && std::abs(t.frequency_hz - hz) < 1e-9 && t.eye == eye)
      return &t;
  return nullptr;
}

TEST(Vor, DefaultRobotCalibratedMapsCounterRotateAndTheGainMatchesTruth) {
  const sim::RobotTruth t = Truth("");
  const Recorded r = Record("default", t, FromTruth(t));
  ExpectMatchesTruth(r);
  // With the true maps the eyes cancel most of the slip the still eyes see.
  for (int e = 0; e < 2; ++e) {
    const evaluation::VorTrialEye* still = Find(r.study, "still", 0.5, e);
    const evaluation::VorTrialEye* vor = Find(r.study, "vor", 0.5, e);
    ASSERT_TRUE(still && vor);
    EXPECT_LT(vor->slip.rms_deg_per_s, 0.5 * still->slip.rms_deg_per_s);
    EXPECT_NEAR(vor->true_gain->gain, 1.0, 0.15);
  }
  const std::string page = reports::WriteVorStudy(r.study, r.dir + "/out", false);
  EXPECT_TRUE(fs::exists(page));
  for (const char* f : {"tables/vor_results.csv",
                        "tables/vor_summary.csv",
                        "tables/vor_frames.csv",
                        "figures/vor_traces.csv",
                        "figures/vor_slip.csv",
                        "figures/vor_gain.csv",
                        "vor.json"})
    EXPECT_TRUE(fs::exists(r.dir + "/out/" + f)) << f;
}

TEST(Vor, VariantANominalMapsMeasureTheGainTheyGetNotTheOneTheyAskFor) {
  // No calibration: the eyes move on the robot file's nominal maps, which are wrong for this robot;
  // the gain measured from the frames still follows the truth, and the report says "nominal".
  const sim::RobotTruth t = Truth("data/sim/owl_variant_a_truth.yaml");
  const Recorded r =
      Record("variant_a_nominal", t, std::nullopt, VorProtocol("{sines_hz: [1.0], cycles: 2, steps_deg: []}"));
  ExpectMatchesTruth(r, 2, 0.03);
  EXPECT_NE(r.study.map.find("nominal"), std::string::npos) << r.study.map;
  ASSERT_FALSE(r.study.notes.empty());
  EXPECT_NE(r.study.notes.front().find("NOMINAL"), std::string::npos);
}

TEST(Vor, VariantACalibratedMaps) {
  const sim::RobotTruth t = Truth("data/sim/owl_variant_a_truth.yaml");
  const Recorded r = Record("variant_a", t, FromTruth(t));
  ExpectMatchesTruth(r);
  const evaluation::VorTrialEye* vor = Find(r.study, "vor", 1.0, models::kRightEye);
  ASSERT_TRUE(vor);
  EXPECT_NEAR(vor->true_gain->gain, 1.0, 0.15);
}

TEST(Vor, ProtocolRefusesSinesAboveTheSlewBound) {
  const std::string bad = R"(name: fast
target: fixation
steps:
  - vor: {sines_hz: [2.0], amplitude_deg: 20}
)";
  try {
    protocols::ParseProtocolYaml(bad, "fast.yaml");
    FAIL() << "a 2 Hz 20 deg sine (251 deg/s) was accepted";
  } catch (const protocols::ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("max_neck_deg_per_s"), std::string::npos) << e.what();
  }
}

}  // namespace vor_study_test
}  // namespace owlcal::pipeline
