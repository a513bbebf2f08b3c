#include "robot/servo_server.h"

#include <gtest/gtest.h>
#include <sys/socket.h>

#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "robot/packet_codec.h"
#include "robot/socket_util.h"

namespace owlcal::robot {
namespace servo_server_test {

using namespace std::chrono_literals;

// Collects what the server hands on, so a test can wait for it.
struct Recorder {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<models::PwmVector> packets;
  std::vector<std::string> raw;

  void Add(const models::PwmVector& p) {
    std::lock_guard<std::mutex> lock(mutex);
    packets.push_back(p);
    cv.notify_all();
  }
  void AddRaw(const std::string& r) {
    std::lock_guard<std::mutex> lock(mutex);
    raw.push_back(r);
  }
  bool WaitFor(size_t n) {
    std::unique_lock<std::mutex> lock(mutex);
    return cv.wait_for(lock, 5s, [&] { return packets.size() >= n; });
  }
};

std::string ReadReply(int fd, size_t n) {
  std::string out;
  char buf[64];
  while (out.size() < n) {
    const int64_t got = RecvSome(fd, buf, static_cast<int64_t>(n - out.size()), 2000ms);
    if (got <= 0) break;
    out.append(buf, static_cast<size_t>(got));
  }
  return out;
}

class ServoServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<ServoServer>(
        ServoServerOptions{},
        [this](const models::PwmVector& p) { rec_.Add(p); },
        [this](const std::string& r) { rec_.AddRaw(r); });
    server_->Start();
    ASSERT_GT(server_->Port(), 0);
  }
  Recorder rec_;
  std::unique_ptr<ServoServer> server_;
};

TEST_F(ServoServerTest, AnswersOkAndHandsOnTheDecodedPacket) {
  Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "1545 1530 1545 1580 1530"));
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
  ASSERT_TRUE(rec_.WaitFor(1));
  EXPECT_EQ(rec_.packets[0], (models::PwmVector{1545, 1530, 1545, 1580, 1530}));
}

TEST_F(ServoServerTest, JoinsSplitReadsAndClampsToTheLimits) {
  Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
  const std::string packet = "2100 1000 1545 1580 1950";
  ASSERT_TRUE(SendAll(s.fd(), packet.substr(0, 7)));
  std::this_thread::sleep_for(30ms);
  ASSERT_TRUE(SendAll(s.fd(), packet.substr(7, 10)));
  std::this_thread::sleep_for(30ms);
  ASSERT_TRUE(SendAll(s.fd(), packet.substr(17)));
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
  ASSERT_TRUE(rec_.WaitFor(1));
  EXPECT_EQ(rec_.packets[0], (models::PwmVector{1890, 1120, 1545, 1580, 1950}));
  EXPECT_EQ(server_->Stats().num_clamped, 1);
  EXPECT_EQ(rec_.raw[0], packet);
}

TEST_F(ServoServerTest, TwoPacketsInOneWriteAreTwoCommands) {
  Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "1500 1500 1500 1500 15001600 1600 1600 1600 1600"));
  EXPECT_EQ(ReadReply(s.fd(), 4), "okok");
  ASSERT_TRUE(rec_.WaitFor(2));
  EXPECT_EQ(rec_.packets[1], (models::PwmVector{1600, 1600, 1600, 1600, 1600}));
}

TEST_F(ServoServerTest, MalformedPacketIsCountedAndMovesNothing) {
  Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "15x5 1530 1545 1580 1530"));
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");  // answered before parsing
  ASSERT_TRUE(SendAll(s.fd(), "1545 1530 1545 1580 1530"));
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
  ASSERT_TRUE(rec_.WaitFor(1));
  EXPECT_EQ(rec_.packets.size(), 1u);
  EXPECT_EQ(server_->Stats().num_malformed, 1);
}

TEST_F(ServoServerTest, ShortPacketEndsTheSessionAndTheNextClientIsServed) {
  {
    Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
    ASSERT_TRUE(SendAll(s.fd(), "1545 15"));
    ::shutdown(s.fd(), SHUT_WR);  // the host closes: a short final packet
    EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
    char c;
    EXPECT_EQ(RecvSome(s.fd(), &c, 1, 2000ms), 0) << "server should close the session";
  }
  for (int client = 0; client < 3; ++client) {
    Socket s = ConnectTcp("127.0.0.1", server_->Port(), 1000ms);
    ASSERT_TRUE(SendAll(s.fd(), EncodePacket({1500 + client, 1530, 1545, 1580, 1530})));
    EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
  }
  ASSERT_TRUE(rec_.WaitFor(3));
  EXPECT_EQ(rec_.packets[2][0], 1502);
  EXPECT_EQ(server_->Stats().num_short, 1);
  EXPECT_EQ(rec_.packets.size(), 3u);
}

TEST(ServoServer, RxValueReplyLikeTheCServer) {
  ServoServerOptions opts;
  opts.reply_style = ServoServerOptions::ReplyStyle::kRxValue;
  ServoServer server(opts, nullptr);
  server.Start();
  Socket s = ConnectTcp("127.0.0.1", server.Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "1999 1530 1545 1580 1530"));
  EXPECT_EQ(ReadReply(s.fd(), 4), "1890");
  server.Stop();
  EXPECT_FALSE(server.Running());
}

TEST(ServoServer, StalledPartialPacketEndsTheSession) {
  ServoServerOptions opts;
  opts.partial_timeout = 200ms;
  ServoServer server(opts, nullptr);
  server.Start();
  Socket s = ConnectTcp("127.0.0.1", server.Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "1545 1530 1545 1580 1530"));  // one whole packet
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");
  ASSERT_TRUE(SendAll(s.fd(), "1545 15"));  // then half of one, and silence
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(ReadReply(s.fd(), 2), "ok");  // the short packet is answered, then the session ends
  char c;
  EXPECT_EQ(RecvSome(s.fd(), &c, 1, 3000ms), 0);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 150ms);
  EXPECT_EQ(server.Stats().num_short, 1);
  EXPECT_EQ(server.Stats().num_packets, 1);
}

TEST(ServoServer, StopIsPromptWithAClientConnected) {
  ServoServer server({}, nullptr);
  server.Start();
  Socket s = ConnectTcp("127.0.0.1", server.Port(), 1000ms);
  const auto t0 = std::chrono::steady_clock::now();
  server.Stop();
  EXPECT_LT(std::chrono::steady_clock::now() - t0, 2s);
  server.Stop();  // idempotent
}

}  // namespace servo_server_test
}  // namespace owlcal::robot
