// `owlcal sim` layout and server flags and `owlcal shell` as a user runs them:
// the layout flags reach the served truth, a bad --server is a usage error, and `owlcal shell`
// moves, waits and centres over one connection to a C-mode virtual Owl, which then exits.
// Loopback and ephemeral ports only.
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <gtest/gtest.h>

#include "sim/robot_truth.h"
#include "sim/sim_server.h"
#include "tests/apps/run_owlcal.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;
using test_cli::RunOwlcal;

class SimShellCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (test_cli::OwlcalBinary().empty()) GTEST_SKIP() << "the owlcal binary is not built";
    dir_ = fs::temp_directory_path() / ("owlcal_sim_shell_cli_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(SimShellCliTest, LayoutFlagsReachTheTruthAndTheDefaultIsMirrored) {
  const fs::path def = dir_ / "default.yaml", flipped = dir_ / "nomirror_swap.yaml";
  ASSERT_EQ(RunOwlcal("sim --write-truth " + def.string()).exit_code, 0);
  EXPECT_TRUE(sim::LoadRobotTruth(def.string()).robot.mirror_stream);
  EXPECT_FALSE(sim::LoadRobotTruth(def.string()).robot.swap_eyes);
  const auto r = RunOwlcal("sim --no-mirror --swap --write-truth " + flipped.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_FALSE(sim::LoadRobotTruth(flipped.string()).robot.mirror_stream);
  EXPECT_TRUE(sim::LoadRobotTruth(flipped.string()).robot.swap_eyes);
  const auto bad = RunOwlcal("sim --server perl --duration 0.1");
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("not one of owlcal, python, c"), std::string::npos) << bad.output;
}

TEST_F(SimShellCliTest, ShellMovesWaitsAndCentresOverOneConnectionToACServer) {
  sim::SimServerOptions so;
  so.servo_port = 0;
  so.http_port = 0;
  so.servo_mode = robot::ServoServerOptions::Mode::kC;
  sim::SimServer server(so);
  server.Start();
  const fs::path script = dir_ / "session.owl";
  std::ofstream(script) << "move 1600 1530 1545 1580 1530\nwait 0.2\nmove 1500 1530 1545 1580 2500\ncentre\n";
  const auto r = RunOwlcal("shell --robot 127.0.0.1:" + std::to_string(server.ServoPort()) + " " + script.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("reply \"1600\""), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("3 servo commands (1 clamped)"), std::string::npos) << r.output;
  EXPECT_EQ(server.ServoStats().num_sessions, 1);
  EXPECT_EQ(server.ServoStats().num_packets, 3);
  for (int i = 0; i < 300 && !server.ServoServerExited(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_TRUE(server.ServoServerExited());
  // The C server is gone: a second run is refused, naming the address.
  const auto again = RunOwlcal("centre --robot 127.0.0.1:" + std::to_string(server.ServoPort()) + " --timeout-ms 500");
  EXPECT_NE(again.exit_code, 0);
  EXPECT_NE(again.output.find("127.0.0.1:" + std::to_string(server.ServoPort())), std::string::npos) << again.output;
  // A bad script is refused before anything moves, naming file:line.
  std::ofstream(script) << "centre\nmove 1545 1530 1545 1580 0x600\n";
  const auto bad = RunOwlcal("shell --robot 127.0.0.1:1 " + script.string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("session.owl:2:"), std::string::npos) << bad.output;
  server.Stop();
}

}  // namespace
}  // namespace owlcal
