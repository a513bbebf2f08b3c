// The served virtual Owl on loopback: OpenCV's VideoCapture reads the stream, raw TCP
// clients get "ok" per packet, malformed input never moves a servo or wedges the server,
// and the HTTP scene/truth routes work. Loopback (127.0.0.1) and ephemeral ports only.
#include "sim/sim_server.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/videoio.hpp>

#include "robot/mjpeg_client.h"
#include "robot/packet_codec.h"
#include "robot/socket_util.h"

namespace owlcal::sim {
namespace {

using namespace std::chrono_literals;

class SimServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SimServerOptions o;
    o.servo_port = 0;
    o.http_port = 0;
    o.owl.seed = 5;
    server_ = std::make_unique<SimServer>(o);
    server_->Start();
  }
  void TearDown() override { server_->Stop(); }

  robot::Socket Connect() { return robot::ConnectTcp("127.0.0.1", server_->ServoPort(), 2000ms); }

  // Reads a reply of up to 16 bytes (waits up to 2 s).
  static std::string Reply(const robot::Socket& s) {
    char buf[16];
    const int64_t n = robot::RecvSome(s.fd(), buf, sizeof buf, 2000ms);
    return n > 0 ? std::string(buf, size_t(n)) : std::string();
  }

  // HTTP/1.0 request over a raw socket; returns the whole response.
  std::string Http(const std::string& method, const std::string& path, const std::string& body = "") {
    robot::Socket s = robot::ConnectTcp("127.0.0.1", server_->HttpPort(), 2000ms);
    std::string req = method + " " + path + " HTTP/1.0\r\nHost: 127.0.0.1\r\n";
    if (!body.empty())
      req += "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
    req += "\r\n" + body;
    EXPECT_TRUE(robot::SendAll(s.fd(), req));
    std::string out;
    char buf[4096];
    for (;;) {
      const int64_t n = robot::RecvSome(s.fd(), buf, sizeof buf, 3000ms);
      if (n <= 0) break;
      out.append(buf, size_t(n));
    }
    return out;
  }
  static std::string Body(const std::string& response) {
    const size_t p = response.find("\r\n\r\n");
    return p == std::string::npos ? "" : response.substr(p + 4);
  }

  std::unique_ptr<SimServer> server_;
};

TEST_F(SimServerTest, VideoCaptureReadsSideBySideFrames) {
  const std::string url = "http://127.0.0.1:" + std::to_string(server_->HttpPort()) + "/stream/video.mjpeg";
  cv::VideoCapture cap(url, cv::CAP_FFMPEG);
  int read = 0;
  if (cap.isOpened()) {
    cv::Mat frame;
    for (int i = 0; i < 5 && cap.read(frame); ++i) {
      EXPECT_EQ(frame.cols, 1280);
      EXPECT_EQ(frame.rows, 480);
      ++read;
    }
    std::printf("cv::VideoCapture (FFmpeg) read %d frames of 1280x480 from %s\n", read, url.c_str());
    EXPECT_EQ(read, 5);
  } else {
    // Debian's OpenCV without an FFmpeg/HTTP backend: check with the raw MJPEG client instead.
    std::printf("cv::VideoCapture cannot open %s in this OpenCV build; using robot::MjpegClient\n", url.c_str());
    robot::MjpegClientOptions co;
    co.port = server_->HttpPort();
    robot::MjpegClient client(co);
    for (int i = 0; i < 5; ++i) {
      auto f = client.Next(3000ms);
      ASSERT_TRUE(f.has_value());
      EXPECT_EQ(f->stereo.left.cols, 640);
      EXPECT_EQ(f->stereo.right.rows, 480);
    }
  }
}

TEST_F(SimServerTest, RawClientGetsOkPerPacketAndMovesTheServos) {
  robot::Socket s = Connect();
  robot::PwmVector cmd = server_->Owl().Config().Centre();
  for (int i = 0; i < 20; ++i) {
    cmd[models::kRx] = 1545 + 5 * i;
    cmd[models::kNeck] = 1530 - 3 * i;
    ASSERT_TRUE(robot::SendAll(s.fd(), robot::EncodePacket(cmd)));
    EXPECT_EQ(Reply(s), "ok") << "packet " << i;
  }
  s.Close();
  // Packets are applied on the server thread right after the reply; allow it a moment.
  for (int i = 0; i < 100 && server_->Owl().LastCommand() != cmd; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(server_->Owl().LastCommand(), cmd);
  // A value beyond the limits is clamped like the course server does.
  robot::Socket t = Connect();
  robot::PwmVector wild = cmd;
  wild[models::kLx] = 2400;
  ASSERT_TRUE(robot::SendAll(t.fd(), robot::EncodePacket(wild)));
  EXPECT_EQ(Reply(t), "ok");
  t.Close();
  for (int i = 0; i < 100 && server_->Owl().LastCommand()[models::kLx] != 1850; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(server_->Owl().LastCommand()[models::kLx], server_->Owl().Config().servos[models::kLx].max_us);
}

TEST_F(SimServerTest, MalformedPartialAndAbruptClientsNeverMoveAServoOrWedgeTheServer) {
  const robot::PwmVector before = server_->Owl().LastCommand();
  const int64_t packets_before = server_->ServoStats().num_packets;
  std::mt19937 rng(1234);
  {
    robot::Socket s = Connect();
    const std::string valid = robot::EncodePacket(before);
    int replies = 0;
    for (int i = 0; i < 10000; ++i) {
      std::string p(24, ' ');
      if (i % 2 == 0) {
        for (char& c : p) c = char(rng() & 0xFF);  // random bytes
      } else {
        // A valid packet with one field byte made invalid (a digit -> non-digit, a space -> digit).
        p = valid;
        const int pos = int(rng() % 24);
        p[pos] = (pos % 5 == 4) ? char('0' + rng() % 10) : "x- .:/\n\0"[rng() % 8];
      }
      if (robot::DecodePacket(p).pwm_us) continue;  // astronomically unlikely; keep the fuzz malformed
      ASSERT_TRUE(robot::SendAll(s.fd(), p)) << "packet " << i;
      replies += Reply(s) == "ok";
    }
    EXPECT_EQ(replies, 10000);
  }
  // Partial packets: a half packet then an abrupt close; a packet split over three writes.
  for (int i = 0; i < 20; ++i) {
    robot::Socket s = Connect();
    robot::SendAll(s.fd(), robot::EncodePacket({1600, 1600, 1600, 1600, 1600}).substr(0, 1 + i));
  }
  // 1000 connect/close cycles.
  for (int i = 0; i < 1000; ++i) {
    robot::Socket s = Connect();
  }
  EXPECT_EQ(server_->Owl().LastCommand(), before);
  EXPECT_EQ(server_->ServoStats().num_packets, packets_before);
  const robot::ServoServerStats stats = server_->ServoStats();
  std::printf("after fuzz: %lld sessions, %lld malformed, %lld valid packets\n",
              (long long)stats.num_sessions,
              (long long)stats.num_malformed,
              (long long)stats.num_packets);
  EXPECT_GE(stats.num_malformed, 10000);
  // Still serving: a packet split over three writes is joined and applied.
  robot::Socket s = Connect();
  const robot::PwmVector cmd = {1560, 1540, 1530, 1590, 1520};
  const std::string p = robot::EncodePacket(cmd);
  robot::SendAll(s.fd(), p.substr(0, 7));
  std::this_thread::sleep_for(20ms);
  robot::SendAll(s.fd(), p.substr(7, 9));
  std::this_thread::sleep_for(20ms);
  robot::SendAll(s.fd(), p.substr(16));
  EXPECT_EQ(Reply(s), "ok");
  s.Close();
  for (int i = 0; i < 100 && server_->Owl().LastCommand() != cmd; ++i) std::this_thread::sleep_for(10ms);
  EXPECT_EQ(server_->Owl().LastCommand(), cmd);
}

TEST_F(SimServerTest, HttpTruthAndSceneRoutes) {
  const nlohmann::json truth = nlohmann::json::parse(Body(Http("GET", "/truth")));
  EXPECT_EQ(truth["seed"], 5);
  EXPECT_TRUE(truth["robot_truth"]["servos"].contains("Ly"));
  const std::string ok =
      Http("PUT", "/scene/targets/chessboard", R"({"t_m": [0.1, -0.05, 0.8], "rpy_deg": [0, 0, 10]})");
  EXPECT_NE(ok.find(" 200 "), std::string::npos) << ok;
  const auto pose = server_->Owl().TargetPose("chessboard");
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR(pose->translation().z(), 0.8, 1e-12);
  const std::string bad = Http("PUT", "/scene/targets/chessboard", R"({"t_m": [0.1, "x", 0.8]})");
  EXPECT_NE(bad.find(" 400 "), std::string::npos) << bad;
  EXPECT_NEAR(server_->Owl().TargetPose("chessboard")->translation().z(), 0.8, 1e-12);
  // Regression: a pose of 1e308 m was accepted and stored; it is refused and the old pose kept.
  const std::string far = Http("PUT", "/scene/targets/chessboard", R"({"t_m": [1e308, 0, 0.8]})");
  EXPECT_NE(far.find(" 400 "), std::string::npos) << far;
  EXPECT_NE(far.find("from the head"), std::string::npos) << far;
  EXPECT_NEAR(server_->Owl().TargetPose("chessboard")->translation().x(), 0.1, 1e-12);
  const std::string missing = Http("PUT", "/scene/targets/nothing", R"({"t_m": [0, 0, 1]})");
  EXPECT_NE(missing.find(" 404 "), std::string::npos) << missing;
  const std::string hide = Http("PUT", "/scene/targets/aprilgrid", R"({"visible": false})");
  EXPECT_NE(hide.find(" 200 "), std::string::npos) << hide;
  EXPECT_FALSE(server_->Owl().SceneState().Find("aprilgrid")->visible);
}

// Regression: GET /scene/targets/NAME answered 405 for every target, because the route looped over
// a member of a temporary JSON value (undefined behaviour) and fell through to the 405 reply.
TEST_F(SimServerTest, GetOfOneSceneTargetAnswersItsPose) {
  const std::string got = Http("GET", "/scene/targets/chessboard");
  ASSERT_NE(got.find(" 200 "), std::string::npos) << got;
  const nlohmann::json t = nlohmann::json::parse(Body(got));
  EXPECT_EQ(t.at("name"), "chessboard");
  ASSERT_TRUE(t.contains("pose")) << t.dump();
  const auto pose = server_->Owl().TargetPose("chessboard");
  ASSERT_TRUE(pose.has_value());
  EXPECT_NEAR(t["pose"]["t_m"][2].get<double>(), pose->translation().z(), 1e-9);
  const std::string missing = Http("GET", "/scene/targets/nothing");
  EXPECT_NE(missing.find(" 404 "), std::string::npos) << missing;
}

// Regression: like mjpg-streamer, a client that reads slower than the stream gets the newest frame
// each time and the rest are dropped, instead of a queue of seconds-old frames. A client reading
// at 5 fps: after a 1 s warm-up every frame it receives was exposed at most latency + 2 x its own
// frame period ago
// (one period in the socket buffers, one in transit), plus the simulator's own rendering lag
// beyond the latency, which the server measures. Ages come from the frame's X-Timestamp (its
// exposure on the steady clock) and the arrival stamp; the bound uses the client's actual periods,
// so a slow test machine widens it instead of failing. Before the fix the ages grew to
// seconds (~4 MB, ~50 frames queued in the kernel's autotuned send buffer).
TEST_F(SimServerTest, AFiveFpsClientGetsRecentFramesNotAQueue) {
  robot::MjpegClientOptions co;
  co.port = server_->HttpPort();
  co.decode = false;
  robot::MjpegClient client(co);
  const double latency_ms = server_->Owl().Truth().stream.latency_ms;
  auto first = client.Next(3000ms);
  ASSERT_TRUE(first.has_value());
  int64_t previous_arrival_ns = first->stereo.stamp_ns;
  double worst_age_ms = 0, worst_margin_ms = 1e9;
  for (int i = 0; i < 20; ++i) {
    std::this_thread::sleep_for(200ms);  // the client's processing: 5 fps
    auto f = client.Next(3000ms);
    ASSERT_TRUE(f.has_value()) << "frame " << i;
    ASSERT_TRUE(f->server_stamp_us.has_value());
    const double age_ms = (double(f->stereo.stamp_ns) / 1000.0 - double(*f->server_stamp_us)) / 1000.0;
    const double period_ms = double(f->stereo.stamp_ns - previous_arrival_ns) / 1e6;
    previous_arrival_ns = f->stereo.stamp_ns;
    // The simulator's own rendering delay (measured by the server) is not the stream's queue.
    const double render_lag_ms = server_->MaxPublishLagMs();
    // The first 1.4 s is TCP's receive-buffer autotuning on the client: its window grows while
    // it reads, and one extra frame may slip into its buffer; then the bound is 2 periods. (The
    // default stream is a real Owl's, ~125 kB per frame at JPEG 95: the window settles one or
    // two frames later than it did with the older, smaller frames; frame 6 came at 2 periods + 290 ms.)
    const bool warm_up = i < 7;
    // Plus 250 ms for a starved server or client thread on a loaded shared machine (it failed
    // at 654 ms against 543 at load 20): a queue gains about one client period per frame and
    // passes that slack within two frames, so the test still tells the two apart.
    const double bound_ms = latency_ms + render_lag_ms + (warm_up ? 4 : 2) * period_ms + 250;
    EXPECT_LE(age_ms, bound_ms) << "frame " << i << " is " << age_ms << " ms old; the client reads every " << period_ms
                                << " ms; rendering lagged up to " << render_lag_ms << " ms";
    EXPECT_GE(age_ms, latency_ms - 1) << "frame " << i;  // a frame cannot arrive before its latency
    if (warm_up) continue;
    worst_age_ms = std::max(worst_age_ms, age_ms);
    worst_margin_ms = std::min(worst_margin_ms, bound_ms - age_ms);
  }
  std::printf(
      "5 fps client: oldest frame received %.0f ms after exposure (latency %.0f ms, rendering lag up to %.0f "
      "ms), smallest margin to the bound %.0f ms\n",
      worst_age_ms,
      latency_ms,
      server_->MaxPublishLagMs(),
      worst_margin_ms);
}

TEST_F(SimServerTest, HttpGarbageGetsA400AndASilentClientBlocksNoOne) {
  robot::Socket silent = robot::ConnectTcp("127.0.0.1", server_->HttpPort(), 2000ms);  // sends nothing
  {
    robot::Socket s = robot::ConnectTcp("127.0.0.1", server_->HttpPort(), 2000ms);
    ASSERT_TRUE(robot::SendAll(s.fd(),
                               std::string("\x16\x03\x01"
                                           "garbage\r\n\r\n")));
    char buf[512];
    const int64_t n = robot::RecvSome(s.fd(), buf, sizeof buf, 3000ms);
    ASSERT_GT(n, 0);
    const std::string r(buf, size_t(n));
    EXPECT_EQ(r.rfind("HTTP/1.0 400 ", 0), 0u) << r;
    EXPECT_NE(r.find("not an HTTP request line"), std::string::npos) << r;
  }
  EXPECT_NE(Http("GET", "/truth").find(" 200 "), std::string::npos);
}

}  // namespace
}  // namespace owlcal::sim
