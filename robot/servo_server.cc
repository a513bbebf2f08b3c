#include "robot/servo_server.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <stdexcept>
#include <string_view>

#include "robot/packet_assembler.h"
#include "robot/packet_codec.h"

namespace owlcal::robot {
namespace {
constexpr std::chrono::milliseconds kPollStep{50};
}  // namespace

bool ServoServerOptions::Check(std::string* why) const {
  if (port < 0 || port > 65535) {
    if (why) *why = "servo server: port = " + std::to_string(port) + " is not 0..65535";
    return false;
  }
  if (bind_address.empty()) {
    if (why) *why = "servo server: bind_address is empty";
    return false;
  }
  if (partial_timeout.count() <= 0) {
    if (why) *why = "servo server: partial_timeout must be positive";
    return false;
  }
  return true;
}

ServoServer::ServoServer(ServoServerOptions options, PacketHandler on_packet, RawHandler on_raw)
    : options_(std::move(options)),
      on_packet_(std::move(on_packet)),
      on_raw_(std::move(on_raw)),
      guard_(options_.robot, options_.log) {}

ServoServer::~ServoServer() { Stop(); }

void ServoServer::Start() {
  if (running_) return;
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
  listener_ = Listen(options_.bind_address, options_.port, &port_);
  stop_ = false;
  running_ = true;
  thread_ = std::thread([this] { Loop(); });
}

void ServoServer::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  listener_.Close();
  running_ = false;
}

ServoServerStats ServoServer::Stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stats_;
}

void ServoServer::Loop() {
  while (!stop_) {
    if (!WaitReadable(listener_.fd(), kPollStep)) continue;
    Socket client(::accept4(listener_.fd(), nullptr, nullptr, SOCK_CLOEXEC));
    if (!client.valid()) continue;
    const int one = 1;  // replies are tiny writes: do not let Nagle hold them back
    ::setsockopt(client.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.num_sessions;
    }
    if (options_.log) options_.log("servo server: client connected");
    Serve(std::move(client));
    if (options_.log) options_.log("servo server: session ended");
  }
}

void ServoServer::Serve(Socket client) {
  const int fd = client.fd();
  PacketAssembler assembler;
  auto handle = [&](std::string_view packet_view) {
    const std::string packet(packet_view);
    if (on_raw_) on_raw_(packet);
    if (options_.reply_style == ServoServerOptions::ReplyStyle::kOk) {
      SendAll(fd, "ok");  // before parsing, like the course server
    }
    const DecodeResult decoded = DecodePacket(packet);
    if (!decoded.pwm_us) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        ++stats_.num_malformed;
      }
      if (options_.log) options_.log("servo server: malformed packet ignored: " + decoded.error);
      if (options_.reply_style == ServoServerOptions::ReplyStyle::kRxValue) SendAll(fd, "0");
      return;
    }
    const ClampResult clamped = guard_.Clamp(*decoded.pwm_us);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.num_packets;
      if (clamped.any_clamped) ++stats_.num_clamped;
    }
    if (options_.reply_style == ServoServerOptions::ReplyStyle::kRxValue) {
      SendAll(fd, std::to_string(clamped.pwm_us[models::kRx]));
    }
    if (on_packet_) on_packet_(clamped.pwm_us);
  };
  char buf[4096];
  auto partial_since = std::chrono::steady_clock::now();
  while (!stop_) {
    const int64_t got = RecvSome(fd, buf, sizeof(buf), kPollStep);
    if (got == -1) {  // no data yet: keep waiting, unless a partial packet went stale
      if (assembler.Pending() > 0 &&
          std::chrono::steady_clock::now() - partial_since > options_.partial_timeout) {
        break;
      }
      continue;
    }
    if (got <= 0) break;  // EOF (the host closed: the "NULL packet") or error
    const size_t pending_before = assembler.Pending();
    int num_completed = 0;
    assembler.Feed(std::string_view(buf, static_cast<size_t>(got)), [&](std::string_view p) {
      ++num_completed;
      handle(p);
    });
    if (assembler.Pending() > 0 && (pending_before == 0 || num_completed > 0)) {
      partial_since = std::chrono::steady_clock::now();  // a new partial packet started in this read
    }
  }
  if (assembler.Pending() > 0) {
    std::lock_guard<std::mutex> lock(mutex_);
    ++stats_.num_short;
  }
  // The course server also answers the short packet before quitting; the peer may be gone.
  if (options_.reply_style == ServoServerOptions::ReplyStyle::kOk) SendAll(fd, "ok");
}

}  // namespace owlcal::robot
