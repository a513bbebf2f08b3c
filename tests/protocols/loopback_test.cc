// A protocol over loopback against the served virtual Owl (the same TCP servo protocol and
// MJPEG stream as the real robot), through the robot factory's HOST:PORT path (OwlLink).
#include <chrono>
#include <filesystem>
#include <thread>

#include <gtest/gtest.h>

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/owl_link.h"
#include "sim/sim_server.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

TEST(Loopback, RunsAProtocolAgainstTheServedVirtualOwl) {
  sim::SimServerOptions so;
  so.bind_address = "127.0.0.1";
  so.servo_port = 0;
  so.http_port = 0;
  sim::SimServer server(so);
  server.Start();
  robot::OwlLinkOptions lo;  // as owlcal's robot factory (apps/robot_factory.h) links a HOST:PORT
  lo.host = "127.0.0.1";
  lo.servo_port = server.ServoPort();
  lo.http_port = server.HttpPort();
  lo.robot = models::DefaultRobotConfig();
  std::unique_ptr<robot::RobotInterface> robot = std::make_unique<robot::OwlLink>(lo);
  EXPECT_EQ(robot->Scene(), nullptr);  // a networked robot: placements are prompts
  const Protocol p = ParseProtocolYaml(R"(
name: loopback
target: chessboard
steps:
  - move-to: {pose: {Rx: centre+40}, settle: {mode: time, time_ms: 300}, frames: 2}
  - sweep: {servo: Lx, from: centre-20, to: centre+20, step_us: 20, both_directions: false,
            settle: {mode: time, time_ms: 200}}
  - place-target: {target: chessboard, distance_m: 0.6}
  - capture: {frames: 3, settle: {mode: image, min_ms: 150, max_ms: 1500, still_px: 1.0}}
)",
                                       "loopback.yaml");
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_loopback_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  o.robot_spec = "127.0.0.1";
  const RunSummary s = RunProtocols({p}, *robot, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  const DatasetCheck c = CheckDataset(o.out_dir);
  EXPECT_TRUE(c.ok);
  EXPECT_EQ(c.num_frames, 2 + 3 + 3);
  const auto frames = ReadFramesCsv(o.out_dir);
  ASSERT_EQ(frames.size(), 8u);
  EXPECT_EQ(frames[0].pwm_us[models::kRx], robot->Config().servos[models::kRx].centre_us + 40);
  EXPECT_GT(frames[0].jpeg_bytes, 10000);
  for (size_t i = 1; i < frames.size(); ++i) EXPECT_GT(frames[i].stamp_ns, frames[i - 1].stamp_ns);
  const auto placements = ReadPlacementsCsv(o.out_dir);
  ASSERT_EQ(placements.size(), 1u);
  EXPECT_EQ(placements[0].source, "file");
  // The served robot received the commands and was parked at its centre. The server answers
  // "ok" before it parses the packet (as the course server does), so the park may reach the
  // virtual Owl just after the client saw its "ok": wait for it, up to 5 s.
  const auto centre = robot->Config().Centre();
  for (int i = 0; i < 500 && server.Owl().LastCommand() != centre; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_EQ(server.Owl().LastCommand(), centre);
  EXPECT_GE(server.ServoStats().num_packets, 5);
  robot.reset();
  server.Stop();
}

}  // namespace
}  // namespace owlcal::protocols
