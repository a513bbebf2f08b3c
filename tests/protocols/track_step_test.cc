// The track step and the lk locator in protocol files: the standard track protocol parses and
// plans, bad values name their key, and a fixate step with `locator: lk` (Lucas-Kanade seeded by
// the disc detector) centres the disc on the virtual Owl like the disc locator does.
#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

TEST(TrackStep, StandardProtocolParsesAndPlans) {
  const Protocol p = LoadProtocolFile(ResolveProtocolPath("track"));
  const TrackStep* t = nullptr;
  for (const Step& s : p.steps)
    if (s.kind() == StepKind::kTrack) t = &s.As<TrackStep>();
  ASSERT_TRUE(t);
  EXPECT_DOUBLE_EQ(t->leave_deg, 32);
  EXPECT_EQ(t->salience_candidates, 3);
  int64_t clamped = -1;
  const std::vector<std::string> plan = PlanRun({p}, models::DefaultRobotConfig(), &clamped);
  EXPECT_EQ(clamped, 0);
  bool mentions = false;
  for (const std::string& line : plan) mentions |= line.find("track:") != std::string::npos;
  EXPECT_TRUE(mentions);
}

TEST(TrackStep, BadValuesNameTheirKey) {
  const std::string head = "name: t\ntarget: fixation\nsteps:\n  - track: ";
  for (const char* bad :
       {"{leave_deg: 50}", "{frequency_hz: 3}", "{gain: 1.5}", "{salience_candidates: 11}", "{no_such_key: 1}"}) {
    try {
      ParseProtocolYaml(head + bad + "\n", "t.yaml");
      ADD_FAILURE() << bad << " was accepted";
    } catch (const ProtocolError& e) {
      EXPECT_NE(std::string(e.what()).find("t.yaml"), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(ParseProtocolYaml(head + "{leave_deg: 0, salience_candidates: 0}\n", "t.yaml"));
}

// One fixation of a disc 8 cm right and 5 cm up at 1 m with the given locator: fixations.csv's row.
calib::CsvTable FixateWith(const std::string& locator) {
  const Protocol p = ParseProtocolYaml(
      "name: fixate-lk\ntarget: fixation\n"
      "targets:\n  fixation: {target_type: fixation, fixation_radius_m: 0.012}\n"
      "steps:\n"
      "  - move-to: {pose: {}, settle: {mode: time, time_ms: 300}}\n"
      "  - place-target: {target: fixation, distance_m: 1.0, offset_m: [0.08, -0.05]}\n"
      "  - fixate: {eyes: both, locator: " +
          locator + ", gain: 0.2, max_iterations: 90}\n",
      "fixate-lk.yaml");
  sim::VirtualOwlOptions vo;
  vo.seed = 2;
  sim::VirtualOwl owl(vo);
  RunOptions ro;
  const fs::path dir = fs::temp_directory_path() / ("owlcal_fixate_" + locator + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  ro.out_dir = dir.string();
  ro.robot_spec = "sim";
  const RunSummary s = RunProtocols({p}, owl, ro);
  EXPECT_EQ(s.status, "complete") << s.message;
  calib::CsvTable t = ReadAppendedCsv(dir.string() + "/fixations.csv");
  fs::remove_all(dir);
  return t;
}

TEST(TrackStep, FixateWithTheLkLocatorCentresTheDiscLikeTheDiscLocator) {
  const calib::CsvTable lk = FixateWith("lk");
  const calib::CsvTable disc = FixateWith("fixation");
  ASSERT_EQ(lk.NumRows(), 1u);
  ASSERT_EQ(disc.NumRows(), 1u);
  EXPECT_EQ(lk.Text(0, "status"), "ok") << lk.Text(0, "reason");
  EXPECT_EQ(disc.Text(0, "status"), "ok") << disc.Text(0, "reason");
  // The seated command lies on a 5 us grid (~5.8 px a step), so the residual is up to half a
  // step; the LK-tracked fixation ends at the same residual as the disc locator's.
  for (const char* c : {"left_dx_px", "left_dy_px", "right_dx_px", "right_dy_px"}) {
    EXPECT_LT(std::abs(lk.Number(0, c)), 3.0) << c;
    EXPECT_NEAR(lk.Number(0, c), disc.Number(0, c), 0.3) << c;
  }
}

}  // namespace
}  // namespace owlcal::protocols
