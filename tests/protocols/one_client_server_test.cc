// owlcal against a one-client servo server: the virtual Owl served with the course's
// C server behaviour (`owlcal sim --server c`: MRSsocket.c serves one client, then dies of
// SIGPIPE when it leaves). A protocol run and a shell session each complete over ONE
// connection; after they close, the server is gone, as on the real robot.
#include <chrono>
#include <filesystem>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>
#include <unistd.h>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/owl_link.h"
#include "robot/shell_script.h"
#include "robot/socket_util.h"
#include "sim/sim_server.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;
using namespace std::chrono_literals;

sim::SimServerOptions CServerOptions() {
  sim::SimServerOptions so;
  so.servo_port = 0;
  so.http_port = 0;
  so.servo_mode = robot::ServoServerOptions::Mode::kC;
  return so;
}

bool WaitExited(const sim::SimServer& server) {
  for (int i = 0; i < 300 && !server.ServoServerExited(); ++i) std::this_thread::sleep_for(10ms);
  return server.ServoServerExited();
}

TEST(OneClientServer, AProtocolCompletesOverOneConnectionToTheCServer) {
  sim::SimServer server(CServerOptions());
  server.Start();
  std::vector<std::string> link_log;
  robot::OwlLinkOptions lo;  // as owlcal's robot factory (apps/robot_factory.h) links a HOST:PORT
  lo.host = "127.0.0.1";
  lo.servo_port = server.ServoPort();
  lo.http_port = server.HttpPort();
  lo.log = [&](const std::string& line) { link_log.push_back(line); };
  std::unique_ptr<robot::RobotInterface> robot = std::make_unique<robot::OwlLink>(lo);
  const Protocol p = ParseProtocolYaml(R"(
name: one-client
target: chessboard
steps:
  - move-to: {pose: {Rx: centre+40}, settle: {mode: time, time_ms: 300}, frames: 2}
  - sweep: {servo: Lx, from: centre-20, to: centre+20, step_us: 20, both_directions: false,
            settle: {mode: time, time_ms: 200}}
  - place-target: {target: chessboard, distance_m: 0.6}
  - capture: {frames: 3, settle: {mode: image, min_ms: 150, max_ms: 1500, still_px: 1.0}}
)",
                                       "one-client.yaml");
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_one_client_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  o.robot_spec = "127.0.0.1";
  const RunSummary s = RunProtocols({p}, *robot, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  EXPECT_EQ(CheckDataset(o.out_dir).num_frames, 2 + 3 + 3);
  EXPECT_FALSE(server.ServoServerExited());  // still connected: one session for the whole run
  EXPECT_EQ(server.ServoStats().num_sessions, 1);
  EXPECT_GE(server.ServoStats().num_packets, 5);
  for (const std::string& line : link_log) EXPECT_EQ(line.find("re-opened"), std::string::npos) << line;
  robot.reset();  // the run ends: the C server's client leaves
  ASSERT_TRUE(WaitExited(server));
  EXPECT_NE(server.ServoServerExitReason().find("SIGPIPE"), std::string::npos);
  EXPECT_THROW(robot::ConnectTcp("127.0.0.1", server.ServoPort(), 500ms), std::runtime_error);
  server.Stop();
  fs::remove_all(o.out_dir);
}

TEST(OneClientServer, AShellSessionMovesWaitsAndCentresOverOneConnection) {
  sim::SimServer server(CServerOptions());
  server.Start();
  const std::vector<robot::ShellCommand> script = robot::ParseShellScript(
      "# a student's session on a C-server Owl\n"
      "move 1600 1530 1545 1580 1500\n"
      "wait 0.2\n"
      "move 1500 1530 1590 992 1500   # Ly below its limit: clamped\n"
      "wait 0.1\n"
      "centre\n",
      "session.owl");
  ASSERT_EQ(script.size(), 5u);
  robot::OwlLinkOptions lo;
  lo.host = "127.0.0.1";
  lo.servo_port = server.ServoPort();
  lo.http_port = server.HttpPort();
  robot::OwlLink link(lo);
  std::ostringstream out;
  const robot::ShellResult r = robot::RunShellScript(script, link, out);
  EXPECT_EQ(r.num_moves, 3);
  EXPECT_EQ(r.num_clamped, 1);
  EXPECT_NEAR(r.waited_s, 0.3, 1e-12);
  std::printf("%s", out.str().c_str());
  EXPECT_NE(out.str().find("reply \"1600\""), std::string::npos) << out.str();  // the C server's Rx echo
  EXPECT_NE(out.str().find("clamped"), std::string::npos);
  EXPECT_EQ(server.ServoStats().num_sessions, 1);
  EXPECT_EQ(server.ServoStats().num_packets, 3);
  const auto centre = link.Config().Centre();
  for (int i = 0; i < 300 && server.Owl().LastCommand() != centre; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(server.Owl().LastCommand(), centre);
  link.Close();
  ASSERT_TRUE(WaitExited(server));
  server.Stop();
}

TEST(OneClientServer, ShellScriptErrorsNameTheLineBeforeAnythingMoves) {
  EXPECT_THROW(robot::ParseShellScript("move 1545 1530 1545 1580\n", "s.owl"), std::invalid_argument);
  for (const char* bad : {"move 1545 1530 1545 1580 0x600",
                          "move 1545 1530 1545 1580 ''",
                          "wait -1",
                          "wait nan",
                          "wait 1e9",
                          "fly 3",
                          "centre now"}) {
    try {
      robot::ParseShellScript(std::string("centre\n") + bad + "\n", "s.owl");
      ADD_FAILURE() << bad;
    } catch (const std::invalid_argument& e) {
      EXPECT_EQ(std::string(e.what()).rfind("s.owl:2: ", 0), 0u) << e.what();
    }
  }
  EXPECT_EQ(robot::PrintableReply(std::string("1545\n\r\x01", 7)), "1545\\n\\r\\x01");
}

}  // namespace
}  // namespace owlcal::protocols
