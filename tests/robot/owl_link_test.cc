// Servo client, OwlLink and HOST[:PORT] parsing against the loopback servers.
#include "robot/owl_link.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <thread>

#include <opencv2/imgcodecs.hpp>

#include "robot/mjpeg_server.h"
#include "robot/packet_codec.h"
#include "robot/servo_client.h"
#include "robot/servo_server.h"
#include "robot/socket_util.h"
#include "tests/robot/raw_server.h"

namespace owlcal::robot {
namespace {

using namespace std::chrono_literals;

struct RawLog {
  std::mutex mutex;
  std::vector<std::string> raw;
  std::vector<models::PwmVector> moved;
  std::vector<std::string> Raw() {
    std::lock_guard<std::mutex> lock(mutex);
    return raw;
  }
  std::vector<models::PwmVector> Moved() {
    std::lock_guard<std::mutex> lock(mutex);
    return moved;
  }
};

std::unique_ptr<ServoServer> MakeServer(RawLog* log, ServoServerOptions opts = {}) {
  auto s = std::make_unique<ServoServer>(
      opts,
      [log](const models::PwmVector& p) {
        std::lock_guard<std::mutex> lock(log->mutex);
        log->moved.push_back(p);
      },
      [log](const std::string& r) {
        std::lock_guard<std::mutex> lock(log->mutex);
        log->raw.push_back(r);
      });
  s->Start();
  return s;
}

TEST(ServoClient, SendsTheExactBytesAndReadsOk) {
  RawLog log;
  auto server = MakeServer(&log);
  ServoClient client({.host = "127.0.0.1", .port = server->Port()});
  const std::vector<models::PwmVector> commands = {
      {1545, 1530, 1545, 1580, 1530}, {1200, 1120, 1180, 2000, 1100}, {1890, 2000, 1850, 1180, 1950}};
  for (const auto& c : commands) {
    const ServoClientReply r = client.Send(c);
    EXPECT_TRUE(r.ok) << r.error;
    EXPECT_EQ(r.text, "ok");
    EXPECT_EQ(r.attempts, 1);
  }
  client.Close();
  const auto raw = log.Raw();
  ASSERT_EQ(raw.size(), 3u);
  EXPECT_EQ(raw[0], "1545 1530 1545 1580 1530");
  EXPECT_EQ(raw[1], "1200 1120 1180 2000 1100");
  EXPECT_EQ(raw[2], "1890 2000 1850 1180 1950");
  // Close() ended the session with the empty packet (EOF), not a short one.
  for (int i = 0; i < 100 && server->Stats().num_sessions < 1; ++i) std::this_thread::sleep_for(5ms);
  EXPECT_EQ(server->Stats().num_short, 0);
  EXPECT_EQ(server->Stats().num_malformed, 0);
}

TEST(ServoClient, AcceptsTheCServersNumericReply) {
  RawLog log;
  ServoServerOptions opts;
  opts.reply_style = ServoServerOptions::ReplyStyle::kRxValue;
  auto server = MakeServer(&log, opts);
  ServoClient client({.host = "127.0.0.1", .port = server->Port()});
  const ServoClientReply r = client.Send({1600, 1530, 1545, 1580, 1530});
  EXPECT_TRUE(r.ok);
  EXPECT_EQ(r.text, "1600");
}

// Regression: the client took any reply as "ok" and printed the server's raw bytes.
TEST(ServoClient, AReplyThatIsNeitherOkNorAnRxEchoIsAnErrorShownPrintable) {
  testing::RawServer hostile([](int) { return std::string("\x1b[2J\x07pwned\xff\r\n"); }, 24, true);
  ServoClient client({.host = "127.0.0.1", .port = hostile.Port(), .reply_timeout = 500ms});
  const ServoClientReply r = client.Send({1545, 1530, 1545, 1580, 1530});
  EXPECT_FALSE(r.ok);
  EXPECT_TRUE(r.bad_reply);
  EXPECT_EQ(r.attempts, 1);  // not resent: the server answered, wrongly
  EXPECT_NE(r.error.find("unexpected reply '?[2J?pwned?'"), std::string::npos) << r.error;
  for (const char c : r.error + r.text) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << int(static_cast<unsigned char>(c));
  // OwlLink turns it into an exception naming the reply.
  OwlLinkOptions o;
  o.host = "127.0.0.1";
  o.servo_port = hostile.Port();
  o.reply_timeout = 500ms;
  OwlLink link(o);
  try {
    link.SendServos(link.Config().Centre());
    ADD_FAILURE() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("unexpected reply"), std::string::npos) << e.what();
  }
}

TEST(ServoClient, AcceptsOkAndRxEchoWithLineEndsOnly) {
  EXPECT_TRUE(IsServoReply("ok"));
  EXPECT_TRUE(IsServoReply("1545"));
  EXPECT_TRUE(IsServoReply("0"));
  EXPECT_FALSE(IsServoReply(""));
  EXPECT_FALSE(IsServoReply("OK!"));
  EXPECT_FALSE(IsServoReply("12345"));
  EXPECT_FALSE(IsServoReply("-100"));
  EXPECT_FALSE(IsServoReply("ok ok"));
  testing::RawServer crlf([](int) { return std::string("ok\r\n"); }, 24, true);
  ServoClient client({.host = "127.0.0.1", .port = crlf.Port()});
  const ServoClientReply r = client.Send({1545, 1530, 1545, 1580, 1530});
  EXPECT_TRUE(r.ok) << r.error;
  EXPECT_EQ(r.text, "ok");
}

// Regression: `--timeout-ms 60000` waited 120 s (connect + reply, and a resend). A command
// timeout bounds the whole command.
TEST(ServoClient, CommandTimeoutBoundsRetriesToo) {
  int port = 0;
  Socket silent = Listen("127.0.0.1", 0, &port);  // accepts (kernel backlog), never answers
  ServoClient client(
      {.host = "127.0.0.1", .port = port, .reply_timeout = 400ms, .max_attempts = 3, .command_timeout = 500ms});
  const auto t0 = std::chrono::steady_clock::now();
  const ServoClientReply r = client.Send({1545, 1530, 1545, 1580, 1530});
  const auto took = std::chrono::steady_clock::now() - t0;
  EXPECT_FALSE(r.ok);
  EXPECT_GE(took, 350ms);  // the first wait ran in full
  EXPECT_LT(took, 700ms);  // not 3 x 400 ms: no resend that cannot finish in time
}

TEST(ServoClient, NextClientIsServedAfterClose) {
  RawLog log;
  auto server = MakeServer(&log);
  for (int i = 0; i < 3; ++i) {
    ServoClient client({.host = "127.0.0.1", .port = server->Port()});
    EXPECT_TRUE(client.Send({1500 + i, 1530, 1545, 1580, 1530}).ok);
  }  // destructor closes
  EXPECT_EQ(log.Moved().size(), 3u);
  EXPECT_EQ(server->Stats().num_sessions, 3);
}

TEST(ServoClient, TimesOutOnASilentServer) {
  int port = 0;
  Socket silent = Listen("127.0.0.1", 0, &port);  // accepts (kernel backlog), never answers
  ServoClient client({.host = "127.0.0.1", .port = port, .reply_timeout = 100ms, .max_attempts = 2});
  const auto t0 = std::chrono::steady_clock::now();
  const ServoClientReply r = client.Send({1545, 1530, 1545, 1580, 1530});
  EXPECT_FALSE(r.ok);
  EXPECT_EQ(r.attempts, 2);
  EXPECT_NE(r.error.find("no reply within 100 ms"), std::string::npos) << r.error;
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
}

TEST(ServoClient, ReconnectsAfterTheServerRestarts) {
  RawLog log;
  auto server = MakeServer(&log);
  const int port = server->Port();
  ServoClient client({.host = "127.0.0.1", .port = port});
  ASSERT_TRUE(client.Send({1545, 1530, 1545, 1580, 1530}).ok);
  server.reset();  // the robot's server restarts
  ServoServerOptions opts;
  opts.port = port;
  server = MakeServer(&log, opts);
  const ServoClientReply r = client.Send({1546, 1530, 1545, 1580, 1530});
  EXPECT_TRUE(r.ok) << r.error;
  EXPECT_EQ(client.NumConnects(), 2);
  EXPECT_EQ(log.Raw().back(), "1546 1530 1545 1580 1530");
}

TEST(ServoClient, RefusesToGuessAHostAndRejectsBadValues) {
  EXPECT_THROW(ServoClient({}), std::invalid_argument);
  RawLog log;
  auto server = MakeServer(&log);
  ServoClient client({.host = "127.0.0.1", .port = server->Port()});
  EXPECT_THROW(client.Send({999, 1530, 1545, 1580, 1530}), std::invalid_argument);
  EXPECT_TRUE(log.Raw().empty());
}

TEST(HostPort, ParsesHostAndOptionalPort) {
  // Parsing only (nothing connects); a documentation address (RFC 5737), not the robot.
  EXPECT_EQ(ParseHostPort("192.0.2.10", 12345).ToString(), "192.0.2.10:12345");
  EXPECT_EQ(ParseHostPort("127.0.0.1:4000", 12345).ToString(), "127.0.0.1:4000");
  EXPECT_EQ(ParseHostPort("localhost:80", 1).host, "localhost");
  EXPECT_THROW(ParseHostPort("", 12345), std::invalid_argument);
  EXPECT_THROW(ParseHostPort(":12345", 12345), std::invalid_argument);
  EXPECT_THROW(ParseHostPort("127.0.0.1:", 12345), std::invalid_argument);
  EXPECT_THROW(ParseHostPort("127.0.0.1:70000", 12345), std::invalid_argument);
  EXPECT_THROW(ParseHostPort("127.0.0.1:12a", 12345), std::invalid_argument);
}

TEST(OwlLink, ClampsSendsAndGrabsFrames) {
  RawLog log;
  auto servo = MakeServer(&log);
  cv::Mat sbs(480, 1280, CV_8UC3, cv::Scalar(0, 0, 0));
  sbs(cv::Rect(0, 0, 640, 480)).setTo(cv::Scalar(255, 255, 255));  // left half white
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", sbs, jpeg);
  MjpegServerOptions mo;
  mo.fps = 60;
  MjpegServer video(mo, [&] { return std::optional(jpeg); });
  video.Start();

  std::vector<std::string> clamp_log;
  OwlLinkOptions o;
  o.host = "127.0.0.1";
  o.servo_port = servo->Port();
  o.http_port = video.Port();
  o.log = [&](const std::string& line) { clamp_log.push_back(line); };
  o.robot.mirror_stream = false;  // the default robot streams mirrored like a real Owl; this frame is not
  OwlLink owl(o);
  EXPECT_NE(owl.Describe().find("127.0.0.1"), std::string::npos);

  const ServoReply r = owl.SendServos({2500, 1530, 1545, 1580, 1530});
  EXPECT_TRUE(r.ok);
  EXPECT_TRUE(r.clamped);
  EXPECT_EQ(r.text, "ok");
  EXPECT_EQ(r.sent[models::kRx], 1890);
  ASSERT_EQ(clamp_log.size(), 1u);
  EXPECT_EQ(log.Raw().at(0), "1890 1530 1545 1580 1530");

  const int64_t t0 = owl.NowNs();
  std::optional<StereoFrame> f = owl.GrabFrame(t0, 5'000'000'000);
  ASSERT_TRUE(f);
  EXPECT_GT(f->stamp_ns, t0);
  EXPECT_EQ(f->left.size(), cv::Size(640, 480));
  EXPECT_GT(cv::mean(f->left)[0], 200);  // left = columns 0-639
  EXPECT_LT(cv::mean(f->right)[0], 50);
  std::optional<StereoFrame> g = owl.GrabFrame(f->stamp_ns, 5'000'000'000);
  ASSERT_TRUE(g);
  EXPECT_GT(g->seq, f->seq);
  owl.Close();
}

TEST(OwlLink, SwapEyesFromTheRobotFile) {
  cv::Mat sbs(480, 1280, CV_8UC3, cv::Scalar(0, 0, 0));
  sbs(cv::Rect(0, 0, 640, 480)).setTo(cv::Scalar(255, 255, 255));
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", sbs, jpeg);
  MjpegServer video({}, [&] { return std::optional(jpeg); });
  video.Start();
  OwlLinkOptions o;
  o.host = "127.0.0.1";
  o.servo_port = 1;  // unused here
  o.http_port = video.Port();
  o.robot.swap_eyes = true;
  o.robot.mirror_stream = false;
  OwlLink owl(o);
  std::optional<StereoFrame> f = owl.GrabFrame(0, 5'000'000'000);
  ASSERT_TRUE(f);
  EXPECT_LT(cv::mean(f->left)[0], 50);
  EXPECT_GT(cv::mean(f->right)[0], 200);
}

TEST(OwlLink, FailsLoudlyWithoutAServer) {
  int port = 0;
  { Socket s = Listen("127.0.0.1", 0, &port); }
  OwlLinkOptions o;
  o.host = "127.0.0.1";
  o.servo_port = port;
  o.http_port = port;
  o.connect_timeout = 200ms;
  OwlLink owl(o);
  EXPECT_THROW(owl.SendServos(owl.Config().Centre()), std::runtime_error);
  EXPECT_FALSE(owl.GrabFrame(0, 300'000'000));
  OwlLinkOptions none;
  EXPECT_THROW(OwlLink{none}, std::invalid_argument);
}

}  // namespace
}  // namespace owlcal::robot
