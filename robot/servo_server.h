#pragma once
// A reusable loopback TCP servo server that behaves like the course's Python server (guide,
// Annex 2), for tests and for the virtual Owl's served mode.
//
// Behaviour, per client (clients are served one after another; after one leaves the next
// queued client is accepted, as many times as needed until Stop()):
//   1. read exactly 24 bytes (kPacketBytes), joining split reads;
//   2. answer the reply ("ok" by default) BEFORE parsing, like the course server;
//   3. a short read (EOF before 24 bytes, or a partial packet that stays incomplete for
//      options.partial_timeout) ends that session: the course's "empty packet" close;
//   4. decode with DecodePacket; a malformed packet is counted and moves nothing (the
//      session continues);
//   5. clamp with a LimitsGuard built from options.robot; call on_packet(clamped) once per
//      valid packet, on the server thread.
// ReplyStyle::kRxValue mimics the C variant of the server, which answers with the (clamped)
// Rx value instead of "ok" (after parsing; "0" for a malformed packet).
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
  std::string bind_address = "127.0.0.1";  // tests and the sim: loopback only
  int port = 0;                            // 0 = ephemeral; Port() tells the chosen one
  enum class ReplyStyle { kOk, kRxValue } reply_style = ReplyStyle::kOk;
  models::RobotConfig robot = models::DefaultRobotConfig();  // limits for the guard
  std::chrono::milliseconds partial_timeout{1000};  // a half packet this old ends the session
  LogSink log;                                       // clamps, malformed packets, sessions
  bool Check(std::string* why) const;
};

struct ServoServerStats {
  int64_t num_sessions = 0;    // clients accepted
  int64_t num_packets = 0;     // valid packets (on_packet calls)
  int64_t num_malformed = 0;   // 24-byte packets DecodePacket rejected
  int64_t num_clamped = 0;     // valid packets the guard changed
  int64_t num_short = 0;       // sessions that ended with a non-empty short packet
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
  // The bound port (valid after Start()).
  int Port() const { return port_; }
  ServoServerStats Stats() const;

 private:
  void Loop();
  void Serve(Socket client);

  ServoServerOptions options_;
  PacketHandler on_packet_;
  RawHandler on_raw_;
  LimitsGuard guard_;
  Socket listener_;
  int port_ = 0;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::thread thread_;
  mutable std::mutex mutex_;  // guards stats_
  ServoServerStats stats_;
};

}  // namespace owlcal::robot
