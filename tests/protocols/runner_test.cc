// The runner against a fast fake robot: limits guard (clamped, reported, never sent),
// dry-run plan, safe abort (parks at centre, dataset closed), resume, placement prompts.
#include <atomic>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/robot_file.h"
#include "sim/virtual_owl.h"
#include "tests/protocols/fake_robot.h"

namespace owlcal::protocols {
namespace runner_test {
namespace fs = std::filesystem;

std::string TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_runner_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

models::RobotConfig TightRobot() {
  models::RobotConfig c = models::DefaultRobotConfig();
  c.servos[models::kRx].min_us = 1400;
  c.servos[models::kRx].max_us = 1700;
  c.servos[models::kNeck].min_us = 1450;
  c.servos[models::kNeck].max_us = 1600;
  return c;
}

const char* kWideSweep = R"(
name: wide
steps:
  - sweep: {servo: Rx, from: 1200, to: 1890, step_us: 100, settle: {mode: time, time_ms: 20}}
  - move-to: {pose: {Neck: 1950, Rx: max}, settle: {mode: time, time_ms: 20}, frames: 1}
  - grid: {pan_us: [-300, 300], neck_us: [-200, 0], settle: {mode: time, time_ms: 20}}
)";

TEST(Runner, TighterRobotFileClampsAndReportsAndNeverSendsOutOfLimits) {
  const models::RobotConfig tight = TightRobot();
  testing::FakeRobot robot(tight);
  const Protocol p = ParseProtocolYaml(kWideSweep, "wide.yaml");
  RunOptions o;
  o.out_dir = TempDir("clamp");
  std::ostringstream progress;
  o.progress = &progress;
  const RunSummary s = RunProtocols({p}, robot, o);
  EXPECT_EQ(s.status, "complete") << s.message;
  EXPECT_GT(s.num_clamped, 5);
  ASSERT_FALSE(robot.requested.empty());
  for (const auto& cmd : robot.requested)
    for (int i = 0; i < models::kNumServos; ++i) {
      EXPECT_GE(cmd[i], tight.servos[i].min_us) << models::kServoNames[i];
      EXPECT_LE(cmd[i], tight.servos[i].max_us) << models::kServoNames[i];
    }
  // Reported: events log, progress output, summary.
  EXPECT_NE(ReadText(o.out_dir + "/events.log").find("clamp"), std::string::npos);
  EXPECT_NE(progress.str().find("CLAMPED"), std::string::npos);
  ASSERT_FALSE(s.clamp_messages.empty());
  EXPECT_NE(s.clamp_messages[0].find("Rx"), std::string::npos) << s.clamp_messages[0];
  // Recorded commands are the ones in force (clamped).
  for (const FrameRecord& f : ReadFramesCsv(o.out_dir)) {
    EXPECT_LE(f.pwm_us[models::kRx], 1700);
    EXPECT_GE(f.pwm_us[models::kRx], 1400);
  }
  // The head was parked at its centre at the end.
  EXPECT_EQ(robot.requested.back(), tight.Centre());
}

TEST(Runner, DryRunPlansAndFlagsClampsWithoutMoving) {
  testing::FakeRobot robot(TightRobot());
  const Protocol p = ParseProtocolYaml(kWideSweep, "wide.yaml");
  RunOptions o;
  o.dry_run = true;
  const RunSummary s = RunProtocols({p}, robot, o);
  EXPECT_EQ(s.status, "dry-run");
  EXPECT_TRUE(robot.requested.empty());
  EXPECT_EQ(robot.frames_grabbed, 0);
  int clamped_lines = 0;
  for (const std::string& l : s.plan) clamped_lines += l.find("CLAMPED") != std::string::npos;
  EXPECT_GT(clamped_lines, 5);
  EXPECT_EQ(clamped_lines, s.num_clamped);
  // Same plan with the guide robot: nothing clamped.
  int64_t n = -1;
  PlanRun({p}, models::DefaultRobotConfig(), &n);
  EXPECT_EQ(n, 0);
}

const char* kCapture = R"(
name: cap
steps:
  - move-to: {pose: {Rx: centre+50}, settle: {mode: time, time_ms: 20}, frames: 2}
  - capture: {frames: 30, settle: {mode: time, time_ms: 5}}
  - move-to: {pose: {Lx: centre-50}, settle: {mode: time, time_ms: 20}, frames: 3}
)";

TEST(Runner, StopRequestParksTheHeadAndClosesTheDataset) {
  testing::FakeRobot robot;
  const Protocol p = ParseProtocolYaml(kCapture, "cap.yaml");
  std::atomic<bool> stop{false};
  RunOptions o;
  o.out_dir = TempDir("abort");
  o.stop_flag = &stop;
  o.on_frame = [&](int64_t index) {
    if (index == 9) stop = true;
  };
  const RunSummary s = RunProtocols({p}, robot, o);
  EXPECT_EQ(s.status, "aborted");
  EXPECT_EQ(s.num_frames, 10);
  EXPECT_EQ(robot.requested.back(), robot.Config().Centre());
  const DatasetCheck c = CheckDataset(o.out_dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.status, "aborted");
  EXPECT_EQ(c.num_frames, 10);
}

// Regression: `timeout` (SIGTERM) or a closed SSH session (SIGHUP) left the head where it was and
// the manifest "running". Each signal now stops the run like Ctrl-C.
TEST(Runner, SigtermAndSighupParkTheHeadLikeSigint) {
  for (const int sig : {SIGTERM, SIGHUP, SIGINT}) {
    SCOPED_TRACE(sig);
    testing::FakeRobot robot;
    const Protocol p = ParseProtocolYaml(kCapture, "cap.yaml");
    RunOptions o;
    o.out_dir = TempDir("signal" + std::to_string(sig));
    o.stop_flag = InstallStopSignals();
    o.on_frame = [&](int64_t index) {
      if (index == 9) std::raise(sig);
    };
    const RunSummary s = RunProtocols({p}, robot, o);
    std::signal(SIGINT, SIG_DFL);
    std::signal(SIGTERM, SIG_DFL);
    std::signal(SIGHUP, SIG_DFL);
    EXPECT_EQ(s.status, "aborted");
    const char* name = sig == SIGTERM ? "SIGTERM" : sig == SIGHUP ? "SIGHUP" : "SIGINT";
    EXPECT_NE(s.message.find(name), std::string::npos) << s.message;
    EXPECT_EQ(s.num_frames, 10);
    EXPECT_EQ(robot.requested.back(), robot.Config().Centre());
    const DatasetCheck c = CheckDataset(o.out_dir);
    EXPECT_TRUE(c.ok);
    EXPECT_EQ(c.status, "aborted");
    EXPECT_NE(ReadText(o.out_dir + "/manifest.json").find("\"aborted\""), std::string::npos);
  }
}

// Regression: a sweep step larger than the servo's range is refused before anything moves.
TEST(Runner, StepLargerThanTheRobotRangeIsRefusedBeforeMoving) {
  testing::FakeRobot robot(TightRobot());
  const Protocol p = ParseProtocolYaml("name: big\nsteps:\n  - sweep: {servo: Neck, step_us: 400}\n", "big.yaml");
  RunOptions o;
  o.out_dir = TempDir("bigstep");
  try {
    RunProtocols({p}, robot, o);
    ADD_FAILURE() << "no error";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "big.yaml:3: step 0 (sweep): field 'step_us': 400 us is more than Neck's range of 150 us"),
              std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(robot.requested.empty());
  int64_t n = 0;
  EXPECT_THROW(PlanRun({p}, TightRobot(), &n), ProtocolError);
}

TEST(Runner, ResumeContinuesAfterTheLastFinishedStep) {
  const Protocol p = ParseProtocolYaml(kCapture, "cap.yaml");
  const std::string dir = TempDir("resume");
  {
    testing::FakeRobot robot;
    std::atomic<bool> stop{false};
    RunOptions o;
    o.out_dir = dir;
    o.stop_flag = &stop;
    o.on_frame = [&](int64_t index) {
      if (index == 12) stop = true;
    };
    EXPECT_EQ(RunProtocols({p}, robot, o).status, "aborted");
  }
  {
    testing::FakeRobot robot;
    RunOptions o;
    o.out_dir = dir;
    o.resume = true;
    const RunSummary s = RunProtocols({p}, robot, o);
    EXPECT_EQ(s.status, "complete") << s.message;
    // 13 frames kept; step 1 (capture 30) re-run, then step 2 (3 frames).
    EXPECT_EQ(s.num_frames, 13 + 30 + 3);
  }
  const DatasetCheck c = CheckDataset(dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.status, "complete");
  std::vector<int> done;
  for (const StepRecord& r : ReadStepsCsv(dir))
    if (r.status == "done") done.push_back(r.step_index);
  EXPECT_EQ(done, (std::vector<int>{0, 1, 2}));
  // The interrupted attempt of step 1 is set aside, not counted twice and not deleted: every
  // step has exactly its own frames, and the old ones are labelled.
  std::map<int, int> per_step;
  int superseded = 0;
  for (const FrameRecord& r : ReadFramesCsv(dir)) {
    ++per_step[r.step_index];
    if (r.step_name.rfind("superseded:", 0) == 0) ++superseded;
  }
  EXPECT_EQ(per_step[1], 30);
  EXPECT_EQ(per_step[2], 3);
  EXPECT_EQ(superseded, per_step[-1]);
  EXPECT_EQ(13 + 30 + 3, per_step[0] + per_step[1] + per_step[2] + per_step[-1]);
  EXPECT_GT(superseded, 0);
  // Resuming with another protocol is refused.
  testing::FakeRobot robot;
  RunOptions o;
  o.out_dir = dir;
  o.resume = true;
  const Protocol other = ParseProtocolYaml("name: other\nsteps:\n  - capture: {frames: 1}\n", "o.yaml");
  EXPECT_THROW(RunProtocols({other}, robot, o), std::runtime_error);
}

TEST(Runner, RealRobotPlacementPromptsAndRecordsTheAnswer) {
  const Protocol p = ParseProtocolYaml(R"(
name: place
target: board
target_description: AprilTag
steps:
  - place-target: {target: board, distance_m: 0.6}
  - capture: {frames: 1, settle: {mode: time, time_ms: 5}}
  - place-target: {target: board, distance_m: 0.9}
)",
                                       "place.yaml");
  testing::FakeRobot robot;  // no scene control, like a real robot
  std::istringstream answers("\n612\n");
  std::ostringstream out;
  RunOptions o;
  o.out_dir = TempDir("prompt");
  o.interactive = true;
  o.input = &answers;
  o.progress = &out;
  EXPECT_EQ(RunProtocols({p}, robot, o).status, "complete");
  EXPECT_NE(out.str().find("Place the AprilTag target 600 mm in front of the neck axis"), std::string::npos)
      << out.str();
  const auto pl = ReadPlacementsCsv(o.out_dir);
  ASSERT_EQ(pl.size(), 2u);
  EXPECT_EQ(pl[0].source, "prompt");
  EXPECT_DOUBLE_EQ(pl[0].distance_m, 0.6);
  EXPECT_DOUBLE_EQ(pl[1].distance_m, 0.612);  // the measured answer replaces the planned 0.9
  EXPECT_EQ(ReadFramesCsv(o.out_dir)[0].placement_index, 0);
  // Non-interactive: the file's values, no prompt read.
  testing::FakeRobot robot2;
  RunOptions o2;
  o2.out_dir = TempDir("noprompt");
  EXPECT_EQ(RunProtocols({p}, robot2, o2).status, "complete");
  const auto pl2 = ReadPlacementsCsv(o2.out_dir);
  ASSERT_EQ(pl2.size(), 2u);
  EXPECT_EQ(pl2[1].source, "file");
  EXPECT_DOUBLE_EQ(pl2[1].distance_m, 0.9);
}

}  // namespace runner_test
}  // namespace owlcal::protocols

namespace owlcal::protocols {
namespace runner_test {

// The same on the in-process virtual Owl, built by the robot factory from a robot file whose
// limits are tighter than the standard servo sweep asks for.
TEST(Runner, TighterRobotFileOnTheVirtualOwlIsClampedAndReported) {
  models::RobotConfig tight = models::DefaultRobotConfig();
  tight.servos[models::kRx].min_us = 1480;
  tight.servos[models::kRx].max_us = 1600;
  tight.servos[models::kNeck].min_us = 1480;
  tight.servos[models::kNeck].max_us = 1580;
  const std::string file = TempDir("tight_robot") + ".yaml";
  {
    std::ofstream out(file);
    out << robot::RobotConfigToYaml(tight);
  }
  // The virtual Owl with that robot file, as owlcal's robot factory (apps/robot_factory.h) makes it.
  sim::VirtualOwlOptions vo;
  sim::RobotTruth truth = sim::DefaultRobotTruth();
  truth.robot = robot::LoadRobotFile(file);
  vo.truth = truth;
  std::unique_ptr<robot::RobotInterface> owl = std::make_unique<sim::VirtualOwl>(vo);
  EXPECT_EQ(owl->Config().servos[models::kRx].max_us, 1600);
  testing::RecordingRobot robot(owl.get());
  const Protocol p = ParseProtocolYaml(R"(
name: tight
steps:
  - sweep: {servo: Rx, from: centre-120, to: centre+120, step_us: 40, settle: {mode: time, time_ms: 100}}
  - sweep: {servo: Neck, from: centre-100, to: centre+100, step_us: 100, settle: {mode: time, time_ms: 100}}
)",
                                       "tight.yaml");
  RunOptions o;
  o.out_dir = TempDir("tight_sim");
  const RunSummary s = RunProtocols({p}, robot, o);
  EXPECT_EQ(s.status, "complete") << s.message;
  EXPECT_GT(s.num_clamped, 4);
  for (const auto& cmd : robot.requested)
    for (int i = 0; i < models::kNumServos; ++i) {
      EXPECT_GE(cmd[i], tight.servos[i].min_us) << models::kServoNames[i];
      EXPECT_LE(cmd[i], tight.servos[i].max_us) << models::kServoNames[i];
    }
  EXPECT_NE(ReadText(o.out_dir + "/events.log").find("clamped to 1600"), std::string::npos);
  EXPECT_TRUE(CheckDataset(o.out_dir).ok);
}

}  // namespace runner_test
}  // namespace owlcal::protocols
