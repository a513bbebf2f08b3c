#pragma once
// TCP client for the Owl's servo server (guide Annex 2: 10.0.0.10:12345).
//
// Send() puts EncodePacket's 24 bytes on the wire and waits up to reply_timeout for any
// short reply: the Python server answers "ok" (before it even parses the packet, so "ok"
// does not confirm motion), a C variant answers with the Rx value. Stale reply bytes are
// drained before each send so replies cannot shift by one.
// On a failed send, or no reply in time, the client reconnects and resends (commands are
// absolute positions, so a repeat is harmless), up to max_attempts in all, and never past
// command_timeout (when set) from the start of the command: connecting, waiting and resending
// together take at most that long.
// The reply must be "ok" (the Python server) or a decimal number of at most four digits (the C
// server's Rx echo, "0" for a packet it could not parse), optionally followed by CR/LF or NUL
// bytes. Anything else is an error (ok = false, not resent), and the error shows the reply
// with printable characters only (io::Printable), so a hostile server cannot write to the
// terminal.
// Close() ends the session the way the course server expects: the host closes its side, so
// the server's recv(24) returns a zero-length ("NULL") packet and its loop ends.
//
// The client does NOT clamp: callers pass commands through LimitsGuard first (OwlLink does).
// EncodePacket throws std::invalid_argument for a value that is not four digits.
//
// Usage:
//   ServoClient client({.host = "127.0.0.1", .port = port});
//   ServoClientReply r = client.Send({1545, 1530, 1545, 1580, 1530});
//   if (!r.ok) ...  // no reply within the timeout after every attempt
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

#include "models/robot_config.h"
#include "robot/socket_util.h"

namespace owlcal::robot {

struct ServoClientOptions {
  std::string host;  // no default: a robot is never assumed
  int port = 12345;
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds reply_timeout{1000};
  int max_attempts = 2;  // sends per command, reconnecting between
  std::chrono::milliseconds reconnect_delay{100};
  std::chrono::milliseconds command_timeout{0};  // > 0: bound on one Send, retries included
  bool Check(std::string* why) const;
};

struct ServoClientReply {
  bool ok = false;         // a valid reply arrived
  std::string text;        // the reply ("ok", or a number from a C server), trailing CR/LF/NUL cut
  bool bad_reply = false;  // a reply arrived but was neither "ok" nor an Rx echo (see error)
  int attempts = 0;        // sends it took
  std::string error;       // why not ok (last failure)
};

// True if `text` (trailing CR, LF and NUL already removed) is a reply a course server gives:
// "ok", or 1-4 decimal digits.
bool IsServoReply(std::string_view text);

class ServoClient {
 public:
  explicit ServoClient(ServoClientOptions options);  // throws std::invalid_argument if !Check
  ~ServoClient();
  ServoClient(const ServoClient&) = delete;
  ServoClient& operator=(const ServoClient&) = delete;

  // Connects now (otherwise the first Send does). Throws std::runtime_error naming host:port.
  void Connect();
  ServoClientReply Send(const models::PwmVector& pwm_us);
  // Sends arbitrary bytes (tests, diagnostics) with the same reply/retry handling.
  ServoClientReply SendBytes(std::string_view bytes);
  // Ends the session (half-close, then close). Safe to call twice; Send reconnects after it.
  void Close();
  bool Connected() const { return socket_.valid(); }
  int64_t NumConnects() const { return num_connects_; }
  const ServoClientOptions& Options() const { return options_; }

 private:
  ServoClientOptions options_;
  Socket socket_;
  int64_t num_connects_ = 0;
};

}  // namespace owlcal::robot
