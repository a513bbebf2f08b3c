// The servo server's python and c modes against the course's own sources:
// the guide's Annex 2 (PFCsocket.py: recv(24), send('ok'), quit on a short packet,
// A = map(int, packet.split(' ')), clamp) and MRSsocket.c (read 32, sscanf "%d %d %d %d %d"
// into globals, atoi reply "%d\n\r", clamp each global, one client then SIGPIPE), and the
// owlcal mode's idle timeout. Loopback, ephemeral ports.
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <sys/socket.h>

#include "robot/course_server_parse.h"
#include "robot/servo_server.h"
#include "robot/socket_util.h"

namespace owlcal::robot {
namespace {

using namespace std::chrono_literals;
using Mode = ServoServerOptions::Mode;

// What the course's Linux OwlSendPacket puts on the wire for a command string: 24 bytes from
// CMD.c_str(), so a 23-character command ends in its NUL terminator.
std::string LinuxOwlSendPacket(const std::string& cmd) {
  std::string wire = cmd;
  wire.resize(24, '\0');
  return wire;
}

TEST(PythonServerParse, FollowsIntOfSplitOnSingleSpaces) {
  auto ok = ParseLikePythonServer("1545 1530 1545 1580 1530");
  ASSERT_TRUE(ok.pwm_us.has_value());
  EXPECT_EQ(*ok.pwm_us, (models::PwmVector{1545, 1530, 1545, 1580, 1530}));
  // The course's tracking loop drove Ly to 992: "992" then the command's NUL in the last field.
  auto nul = ParseLikePythonServer(LinuxOwlSendPacket("1545 1530 1545 992 1530"));
  EXPECT_FALSE(nul.pwm_us.has_value());
  EXPECT_EQ(nul.exception, "ValueError: null byte in argument for int()");
  // Two spaces make an empty field; a leading space too.
  auto two = ParseLikePythonServer("1545 1530 1545  992 1530");
  EXPECT_EQ(two.exception, "ValueError: invalid literal for int() with base 10: ''");
  EXPECT_FALSE(ParseLikePythonServer(" 992 1530 1545 1580 1530").pwm_us.has_value());
  // int() strips whitespace around a field and takes a sign.
  auto ws = ParseLikePythonServer("-100 1530 1545 1580\t1530");
  EXPECT_FALSE(ws.pwm_us.has_value());  // "1580\t1530" is one field: not an int
  auto sign = ParseLikePythonServer("-100 1530 +1545 1580 153\n");
  ASSERT_TRUE(sign.pwm_us.has_value()) << sign.exception;
  EXPECT_EQ((*sign.pwm_us)[0], -100);
  EXPECT_EQ((*sign.pwm_us)[2], 1545);
  EXPECT_EQ((*sign.pwm_us)[4], 153);
  // Four fields: A[4] raises IndexError.
  EXPECT_EQ(ParseLikePythonServer("1545 1530 1545 158001530").exception.rfind("IndexError", 0), 0u);
  EXPECT_EQ(PythonRepr(std::string("99\0x'", 5)), "'99\\x00x\\''");
}

TEST(CServerScan, ParsesFieldByFieldIntoGlobalsThatKeepTheirValues) {
  models::PwmVector g{};  // the C globals start at zero
  CServerScan s = ScanLikeCServer(LinuxOwlSendPacket("1545 1530 1545 992 1530"), &g);
  EXPECT_EQ(s.num_fields, 5);
  EXPECT_EQ(s.data, 1545);
  EXPECT_EQ(g, (models::PwmVector{1545, 1530, 1545, 992, 1530}));
  // A bad field stops sscanf: the later fields keep their previous values.
  s = ScanLikeCServer("1600 1500 1560 99x 1700", &g);
  EXPECT_EQ(s.num_fields, 4);
  EXPECT_EQ(g, (models::PwmVector{1600, 1500, 1560, 99, 1530}));
  // The text ends at a NUL; any amount of whitespace separates fields.
  s = ScanLikeCServer(std::string("  1610\t\t1510\n1570 \0 1234", 24), &g);
  EXPECT_EQ(s.num_fields, 3);
  EXPECT_EQ(g, (models::PwmVector{1610, 1510, 1570, 99, 1530}));
  s = ScanLikeCServer("abc", &g);
  EXPECT_EQ(s.num_fields, 0);
  EXPECT_EQ(s.data, 0);
  EXPECT_EQ(ScanLikeCServer("-2", &g).data, -2);
}

// Collects what a server hands on.
struct Recorder {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<models::PwmVector> packets;
  std::vector<std::string> log;
  void Add(const models::PwmVector& p) {
    std::lock_guard<std::mutex> lock(mutex);
    packets.push_back(p);
    cv.notify_all();
  }
  bool WaitFor(size_t n) {
    std::unique_lock<std::mutex> lock(mutex);
    return cv.wait_for(lock, 5s, [&] { return packets.size() >= n; });
  }
  models::PwmVector Last() {
    std::lock_guard<std::mutex> lock(mutex);
    return packets.back();
  }
};

std::unique_ptr<ServoServer> StartServer(Mode mode, Recorder* rec, std::chrono::milliseconds idle = 5000ms) {
  ServoServerOptions o;
  o.mode = mode;
  o.idle_timeout = idle;
  o.log = [rec](const std::string& line) {
    std::lock_guard<std::mutex> lock(rec->mutex);
    rec->log.push_back(line);
  };
  auto s = std::make_unique<ServoServer>(o, [rec](const models::PwmVector& p) { rec->Add(p); });
  s->Start();
  return s;
}

std::string Reply(const Socket& s, size_t n, std::chrono::milliseconds timeout = 2000ms) {
  std::string out;
  char buf[64];
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (out.size() < n && std::chrono::steady_clock::now() < end) {
    const int64_t got = RecvSome(s.fd(), buf, int64_t(std::min(sizeof(buf), n - out.size())), 100ms);
    if (got == 0 || got == -2) break;
    if (got > 0) out.append(buf, size_t(got));
  }
  return out;
}

bool WaitExited(const ServoServer& s) {
  for (int i = 0; i < 200 && !s.Exited(); ++i) std::this_thread::sleep_for(10ms);
  return s.Exited();
}

TEST(PythonModeServer, AnswersOkMovesAndDiesOnANulLikeAnnex2) {
  Recorder rec;
  auto server = StartServer(Mode::kPython, &rec);
  Socket s = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
  ASSERT_TRUE(SendAll(s.fd(), "1999 1530 1545 1580 1530"));
  EXPECT_EQ(Reply(s, 2), "ok");
  ASSERT_TRUE(rec.WaitFor(1));
  EXPECT_EQ(rec.Last()[0], 1890);  // clamped like the Python server's range check
  ASSERT_TRUE(SendAll(s.fd(), LinuxOwlSendPacket("1545 1530 1545 992 1530")));
  EXPECT_EQ(Reply(s, 2), "ok");  // answered before parsing
  ASSERT_TRUE(WaitExited(*server));
  EXPECT_NE(server->ExitReason().find("ValueError: null byte"), std::string::npos) << server->ExitReason();
  EXPECT_EQ(rec.packets.size(), 1u);  // the bad packet moved nothing, and nothing moves again
  char c;
  EXPECT_EQ(RecvSome(s.fd(), &c, 1, 2000ms), 0);  // the process is gone: its socket closed
  EXPECT_THROW(ConnectTcp("127.0.0.1", server->Port(), 500ms), std::runtime_error);
}

TEST(PythonModeServer, ServesOneClientAndQuitsOnItsNullPacket) {
  Recorder rec;
  auto server = StartServer(Mode::kPython, &rec);
  {
    Socket s = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
    ASSERT_TRUE(SendAll(s.fd(), "1545 1530 1545 1580 1530"));
    EXPECT_EQ(Reply(s, 2), "ok");
    ::shutdown(s.fd(), SHUT_WR);   // the host closes: recv gives 0 bytes
    EXPECT_EQ(Reply(s, 2), "ok");  // the NULL packet is answered too, then the server quits
  }
  ASSERT_TRUE(WaitExited(*server));
  EXPECT_NE(server->ExitReason().find("NULL packet"), std::string::npos);
  EXPECT_THROW(ConnectTcp("127.0.0.1", server->Port(), 500ms), std::runtime_error);
}

TEST(CModeServer, ClampsEachFieldRepliesWithTheRawRxAndKeepsGoodFieldsMoving) {
  Recorder rec;
  auto server = StartServer(Mode::kC, &rec);
  Socket s = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
  // The course's tracking loop: Ly below 1000 us, "992" and a NUL. Lx still moves; Ly clamps.
  ASSERT_TRUE(SendAll(s.fd(), LinuxOwlSendPacket("1545 1530 1600 992 1530")));
  EXPECT_EQ(Reply(s, 6), "1545\n\r");
  ASSERT_TRUE(rec.WaitFor(1));
  EXPECT_EQ(rec.Last(), (models::PwmVector{1545, 1530, 1600, 1180, 1530}));
  // A field that does not parse keeps the previous (clamped) value; the others move.
  ASSERT_TRUE(SendAll(s.fd(), "2500 1540 1610 1x00 1600"));
  EXPECT_EQ(Reply(s, 6), "2500\n\r");  // atoi of the packet: the raw Rx, not the clamped one
  ASSERT_TRUE(rec.WaitFor(2));
  EXPECT_EQ(rec.Last(), (models::PwmVector{1890, 1540, 1610, 1180, 1530}));
  EXPECT_EQ(server->Stats().num_malformed, 1);
  // The client leaves: MRSsocket.c dies of SIGPIPE; the port is closed.
  s.Close();
  ASSERT_TRUE(WaitExited(*server));
  EXPECT_NE(server->ExitReason().find("SIGPIPE"), std::string::npos) << server->ExitReason();
  EXPECT_THROW(ConnectTcp("127.0.0.1", server->Port(), 500ms), std::runtime_error);
}

TEST(CModeServer, ANegativeFirstFieldEndsTheSessionAndMinusTwoTheServer) {
  Recorder rec;
  auto server = StartServer(Mode::kC, &rec);
  {
    Socket s = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
    ASSERT_TRUE(SendAll(s.fd(), "-1"));
    char c;
    EXPECT_EQ(RecvSome(s.fd(), &c, 1, 2000ms), 0);  // closed without a reply
  }
  EXPECT_FALSE(server->Exited());
  Socket t = ConnectTcp("127.0.0.1", server->Port(), 1000ms);  // the next client is accepted
  ASSERT_TRUE(SendAll(t.fd(), "1545 1530 1545 1580 1530"));
  EXPECT_EQ(Reply(t, 6), "1545\n\r");
  ASSERT_TRUE(SendAll(t.fd(), "-2"));
  ASSERT_TRUE(WaitExited(*server));
  EXPECT_NE(server->ExitReason().find("-2"), std::string::npos);
  EXPECT_EQ(rec.packets.size(), 1u);
}

TEST(OwlcalModeServer, ASilentClientIsClosedOnlyWhenAnotherWaits) {
  Recorder rec;
  auto server = StartServer(Mode::kOwlcal, &rec, 300ms);
  Socket silent = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
  std::this_thread::sleep_for(600ms);  // alone: longer than the idle timeout, still served
  ASSERT_TRUE(SendAll(silent.fd(), "1545 1530 1545 1580 1530"));
  EXPECT_EQ(Reply(silent, 2), "ok");
  EXPECT_EQ(server->Stats().num_idle_closed, 0);
  // Now it goes silent while a second client waits: it is closed and the second is served.
  Socket second = ConnectTcp("127.0.0.1", server->Port(), 1000ms);
  ASSERT_TRUE(SendAll(second.fd(), "1600 1530 1545 1580 1530"));
  EXPECT_EQ(Reply(second, 2, 3000ms), "ok");
  ASSERT_TRUE(rec.WaitFor(2));
  EXPECT_EQ(rec.Last()[0], 1600);
  EXPECT_EQ(server->Stats().num_idle_closed, 1);
  char c;
  EXPECT_EQ(RecvSome(silent.fd(), &c, 1, 1000ms), 0);
}

TEST(ServerMode, NamesParseAndUnknownIsRefused) {
  EXPECT_EQ(ParseServerMode("c"), Mode::kC);
  EXPECT_EQ(ParseServerMode("python"), Mode::kPython);
  EXPECT_EQ(ModeName(ParseServerMode("owlcal")), "owlcal");
  EXPECT_THROW(ParseServerMode("C++"), std::invalid_argument);
}

TEST(SocketUtil, LoopbackAddressesAndIpv6Listen) {
  for (const char* a : {"127.0.0.1", "127.0.0.2", "127.1.2.3", "::1", "[::1]", "localhost", "::ffff:127.0.0.1"}) {
    EXPECT_TRUE(IsLoopbackAddress(a)) << a;
  }
  for (const char* a : {"0.0.0.0", "10.1.2.3", "::", "192.168.1.2", "example.org"}) {
    EXPECT_FALSE(IsLoopbackAddress(a)) << a;
  }
  int port = 0;
  Socket l;
  try {
    l = Listen("::1", 0, &port);
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "no IPv6 loopback on this machine: " << e.what();
  }
  EXPECT_GT(port, 0);
  Socket c = ConnectTcp("::1", port, 1000ms);
  EXPECT_TRUE(c.valid());
}

}  // namespace
}  // namespace owlcal::robot
