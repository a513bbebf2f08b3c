#pragma once
// A reusable loopback TCP servo server for tests and for the virtual Owl's served mode, in one
// of three modes (options.mode):
//
// Mode::kOwlcal (default, owlcal's robust server). Clients are served one after another; after
// one leaves the next queued client is accepted, as many times as needed until Stop(). Per client:
//   1. read exactly 24 bytes (kPacketBytes), joining split reads;
//   2. answer the reply ("ok" by default) BEFORE parsing, like the course server;
//   3. a short read (EOF before 24 bytes, or a partial packet that stays incomplete for
//      options.partial_timeout) ends that session: the course's "empty packet" close;
//   4. decode with DecodePacket; a malformed packet is counted and moves nothing (the
//      session continues);
//   5. clamp with a LimitsGuard built from options.robot; call on_packet(clamped) once per
//      valid packet, on the server thread.
//   6. idle timeout: a session that has been silent for options.idle_timeout (5 s) while
//      another client is waiting to connect is closed (logged), so one silent client cannot
//      lock out the rest; a lone client may stay silent as long as it likes.
// ReplyStyle::kRxValue answers with the (clamped) Rx value instead of "ok" (after parsing; "0"
// for a malformed packet).
//
// Mode::kPython: the guide's Annex 2 server (PFCsocket.py) exactly. ONE client is accepted;
// per packet one recv(24) (a short read is not joined: the course server's own bug), "ok"
// before parsing; a read shorter than 24 bytes ends the session AND the server ("received NULL
// packet, quitting"); fields are parsed with robot/course_server_parse.h's Python rules and a bad
// field (a NUL, two spaces, a letter) kills the server with Python's exception, logged. Clamped
// to the robot's limits. After it ends, the port is closed: connecting is refused.
//
// Mode::kC: the course's C server (MRSsocket.c) exactly. Per read of up to 32 bytes, sscanf
// into five persistent values (a field that does not parse keeps its previous value: per-field
// parse), each clamped to its limits, servos set, reply "%d\n\r" of atoi(packet) (the raw Rx).
// A first field < 0 ends the session (the next client is accepted), -2 stops the server. When
// the client leaves, the real server's next reply hits the closed socket and SIGPIPE kills it:
// this server then closes its port too (logged). So it serves ONE client per launch.
//
// Exited() tells when a python or C server has stopped by itself, ExitReason() why.
//
// Usage:
//   ServoServer server({}, [](const models::PwmVector& pwm) { /* move the servos */ });
//   server.Start();                       // binds 127.0.0.1, ephemeral port
//   int port = server.Port();             // connect a client here
//   ...
//   server.Stop();                        // also done by the destructor
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "models/robot_config.h"
#include "robot/limits_guard.h"
#include "robot/socket_util.h"

namespace owlcal::robot {

struct ServoServerOptions {
  enum class Mode { kOwlcal, kPython, kC };
  Mode mode = Mode::kOwlcal;
  std::string bind_address = "127.0.0.1";  // tests and the sim: loopback only
  int port = 0;                            // 0 = ephemeral; Port() tells the chosen one
  enum class ReplyStyle { kOk, kRxValue } reply_style = ReplyStyle::kOk;
  models::RobotConfig robot = models::DefaultRobotConfig();  // limits for the guard
  std::chrono::milliseconds partial_timeout{1000};           // a half packet this old ends the session
  std::chrono::milliseconds idle_timeout{5000};              // kOwlcal: silent this long while another waits
  LogSink log;                                               // clamps, malformed packets, sessions
  bool Check(std::string* why) const;
};

// "owlcal", "python" or "c" (as on the command line).
std::string ModeName(ServoServerOptions::Mode mode);
// Throws std::invalid_argument naming the text for anything else.
ServoServerOptions::Mode ParseServerMode(const std::string& text);

struct ServoServerStats {
  int64_t num_sessions = 0;     // clients accepted
  int64_t num_packets = 0;      // valid packets (on_packet calls)
  int64_t num_malformed = 0;    // 24-byte packets DecodePacket rejected
  int64_t num_clamped = 0;      // valid packets the guard changed
  int64_t num_short = 0;        // sessions that ended with a non-empty short packet
  int64_t num_idle_closed = 0;  // kOwlcal sessions closed by the idle timeout
};

class ServoServer {
 public:
  using PacketHandler = std::function<void(const models::PwmVector&)>;
  // Every 24-byte packet as received (valid or not), before decoding.
  using RawHandler = std::function<void(const std::string&)>;

  ServoServer(ServoServerOptions options, PacketHandler on_packet, RawHandler on_raw = nullptr);
  ~ServoServer();
  ServoServer(const ServoServer&) = delete;
  ServoServer& operator=(const ServoServer&) = delete;

  // Binds and starts the server thread. Throws (naming address:port) if binding fails.
  void Start();
  // Stops accepting, closes the current session and joins the thread. Idempotent.
  void Stop();
  bool Running() const { return running_.load(); }
  // A python or C server that stopped by itself (as the course's would), and why.
  bool Exited() const { return exited_.load(); }
  std::string ExitReason() const;
  // The bound port (valid after Start()).
  int Port() const { return port_; }
  ServoServerStats Stats() const;

 private:
  void Loop();
  void Serve(Socket client);
  // kPython / kC sessions; return true when the server must exit afterwards.
  bool ServePython(Socket client);
  bool ServeC(Socket client);
  void Exit(const std::string& why);
  void Count(int64_t ServoServerStats::*field);

  ServoServerOptions options_;
  PacketHandler on_packet_;
  RawHandler on_raw_;
  LimitsGuard guard_;
  Socket listener_;
  int port_ = 0;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> exited_{false};
  std::string exit_reason_;        // guarded by mutex_
  models::PwmVector c_globals_{};  // kC: MRSsocket.c's freq_* globals (zero at start)
  std::thread thread_;
  mutable std::mutex mutex_;  // guards stats_
  ServoServerStats stats_;
};

}  // namespace owlcal::robot
