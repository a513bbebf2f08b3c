#include "robot/servo_client.h"

#include <sys/socket.h>

#include <stdexcept>
#include <thread>

#include "io/strict_number.h"
#include "robot/packet_codec.h"

namespace owlcal::robot {

bool ServoClientOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "servo client: " + m;
    return false;
  };
  if (host.empty()) return fail("no robot host given (a robot address is never assumed)");
  if (port < 1 || port > 65535) return fail("port = " + std::to_string(port) + " is not 1..65535");
  if (max_attempts < 1) return fail("max_attempts = " + std::to_string(max_attempts) + " is below 1");
  if (reply_timeout.count() <= 0 || connect_timeout.count() <= 0) return fail("timeouts must be positive");
  if (command_timeout.count() < 0) return fail("command_timeout must not be negative");
  return true;
}

bool IsServoReply(std::string_view text) {
  if (text == "ok") return true;
  if (text.empty() || text.size() > 4) return false;
  for (const char c : text) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

ServoClient::ServoClient(ServoClientOptions options) : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
}

ServoClient::~ServoClient() { Close(); }

void ServoClient::Connect() {
  socket_ = ConnectTcp(options_.host, options_.port, options_.connect_timeout);
  ++num_connects_;
}

void ServoClient::Close() {
  if (!socket_.valid()) return;
  // The course server's recv(24) returns 0 bytes once we half-close: its "NULL packet".
  ::shutdown(socket_.fd(), SHUT_WR);
  // Give it a moment to answer and close its side, so its session ends cleanly.
  char buf[64];
  for (int i = 0; i < 4; ++i) {
    if (RecvSome(socket_.fd(), buf, sizeof(buf), std::chrono::milliseconds(50)) <= 0) break;
  }
  socket_.Close();
}

ServoClientReply ServoClient::Send(const models::PwmVector& pwm_us) { return SendBytes(EncodePacket(pwm_us)); }

ServoClientReply ServoClient::SendBytes(std::string_view bytes) {
  using Clock = std::chrono::steady_clock;
  const bool bounded = options_.command_timeout.count() > 0;
  const Clock::time_point deadline = Clock::now() + options_.command_timeout;
  // A wait of at most `wanted`, cut to what is left of the command's time (0 = none left).
  auto budget = [&](std::chrono::milliseconds wanted) {
    if (!bounded) return wanted;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
    return std::max(std::chrono::milliseconds(0), std::min(wanted, left));
  };
  const std::string where = options_.host + ":" + std::to_string(options_.port);
  ServoClientReply reply;
  for (int attempt = 1; attempt <= options_.max_attempts; ++attempt) {
    if (attempt > 1) {
      if (bounded && budget(options_.reconnect_delay) < options_.reconnect_delay) break;
      std::this_thread::sleep_for(options_.reconnect_delay);
    }
    if (bounded && budget(options_.reply_timeout).count() == 0) break;
    reply.attempts = attempt;
    if (!socket_.valid()) {
      try {
        socket_ = ConnectTcp(options_.host, options_.port, budget(options_.connect_timeout));
        ++num_connects_;
      } catch (const std::exception& e) {
        reply.error = e.what();
        continue;
      }
    }
    // Drop stale bytes (a late reply to an earlier packet); EOF here means the server left.
    char buf[256];
    bool closed = false;
    while (WaitReadable(socket_.fd(), std::chrono::milliseconds(0))) {
      if (RecvSome(socket_.fd(), buf, sizeof(buf), std::chrono::milliseconds(0)) <= 0) {
        closed = true;
        break;
      }
    }
    if (closed || !SendAll(socket_.fd(), bytes)) {
      reply.error = where + ": connection lost";
      socket_.Close();
      continue;
    }
    const std::chrono::milliseconds wait = budget(options_.reply_timeout);
    const int64_t got = wait.count() > 0 ? RecvSome(socket_.fd(), buf, sizeof(buf), wait) : -1;
    if (got > 0) {
      std::string text(buf, static_cast<size_t>(got));
      // Collect the rest of a reply split over segments if it is already here (never wait:
      // the reply is one short write, and waiting would add to every command's latency).
      int64_t more;
      while (text.size() < 64 && (more = RecvSome(socket_.fd(), buf, sizeof(buf), std::chrono::milliseconds(0))) > 0) {
        text.append(buf, static_cast<size_t>(more));
      }
      while (!text.empty() && (text.back() == '\r' || text.back() == '\n' || text.back() == '\0')) text.pop_back();
      if (!IsServoReply(text)) {
        // A server that answers something else is not a course server: never take it as "ok".
        reply.bad_reply = true;
        reply.text = io::Printable(text);
        reply.error = where + ": unexpected reply '" + reply.text + "' (" + std::to_string(text.size()) +
                      " bytes; expected 'ok' or the Rx value)";
        return reply;
      }
      reply.text = text;
      reply.ok = true;
      reply.error.clear();
      return reply;
    }
    reply.error = where + (got == -1 ? ": no reply within " + std::to_string(wait.count()) + " ms"
                                     : ": connection closed by the server");
    socket_.Close();
  }
  if (reply.error.empty())
    reply.error = where + ": no reply within " + std::to_string(options_.command_timeout.count()) + " ms";
  return reply;
}

}  // namespace owlcal::robot
