#include "robot/servo_server.h"

#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>

#include <stdexcept>
#include <string_view>

#include "robot/course_server_parse.h"
#include "robot/packet_assembler.h"
#include "robot/packet_codec.h"

namespace owlcal::robot {
namespace {
constexpr std::chrono::milliseconds kServerPollStep{50};
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
  if (idle_timeout.count() <= 0) {
    if (why) *why = "servo server: idle_timeout must be positive";
    return false;
  }
  return true;
}

std::string ModeName(ServoServerOptions::Mode mode) {
  switch (mode) {
    case ServoServerOptions::Mode::kPython:
      return "python";
    case ServoServerOptions::Mode::kC:
      return "c";
    case ServoServerOptions::Mode::kOwlcal:
      break;
  }
  return "owlcal";
}

ServoServerOptions::Mode ParseServerMode(const std::string& text) {
  if (text == "owlcal") return ServoServerOptions::Mode::kOwlcal;
  if (text == "python") return ServoServerOptions::Mode::kPython;
  if (text == "c") return ServoServerOptions::Mode::kC;
  throw std::invalid_argument("servo server mode '" + text + "' is not one of owlcal, python, c");
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

std::string ServoServer::ExitReason() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return exit_reason_;
}

void ServoServer::Count(int64_t ServoServerStats::*field) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++(stats_.*field);
}

void ServoServer::Exit(const std::string& why) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    exit_reason_ = why;
  }
  if (options_.log) options_.log(ModeName(options_.mode) + " servo server exited: " + why);
  listener_.Close();  // as the course's process would: connecting is refused from now on
  exited_ = true;
}

void ServoServer::Loop() {
  while (!stop_ && !exited_) {
    if (!WaitReadable(listener_.fd(), kServerPollStep)) continue;
    Socket client(::accept4(listener_.fd(), nullptr, nullptr, SOCK_CLOEXEC));
    if (!client.valid()) continue;
    const int one = 1;  // replies are tiny writes: do not let Nagle hold them back
    ::setsockopt(client.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.num_sessions;
    }
    if (options_.log) options_.log("servo server: client connected");
    if (options_.mode == ServoServerOptions::Mode::kPython) {
      ServePython(std::move(client));
      return;  // the Python server accepts one client; its script then ends
    }
    if (options_.mode == ServoServerOptions::Mode::kC) {
      if (ServeC(std::move(client))) return;
      continue;
    }
    Serve(std::move(client));
    if (options_.log) options_.log("servo server: session ended");
  }
}

bool ServoServer::ServePython(Socket client) {
  const int fd = client.fd();
  while (!stop_) {
    char buf[kPacketBytes];
    const int64_t got = RecvSome(fd, buf, kPacketBytes, kServerPollStep);  // comm.recv(24): one read
    if (got == -1) continue;
    const std::string packet(buf, got > 0 ? size_t(got) : 0);
    if (on_raw_ && !packet.empty()) on_raw_(packet);
    SendAll(fd, "ok");  // comm.send('ok') before anything is checked
    if (packet.size() < size_t(kPacketBytes)) {
      if (!packet.empty()) Count(&ServoServerStats::num_short);
      Exit("received NULL packet, quitting (recv gave " + std::to_string(packet.size()) +
           " bytes; PFCsocket.py ends on len(packet) < 24)");
      return true;
    }
    const PythonServerParse parsed = ParseLikePythonServer(packet);
    if (!parsed.pwm_us) {
      Count(&ServoServerStats::num_malformed);
      Exit("Traceback: " + parsed.exception + " (packet " + PythonRepr(packet) +
           "; PFCsocket.py does not catch it, so the server dies)");
      return true;
    }
    const ClampResult clamped = guard_.Clamp(*parsed.pwm_us);
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.num_packets;
      if (clamped.any_clamped) ++stats_.num_clamped;
    }
    if (on_packet_) on_packet_(clamped.pwm_us);
  }
  return true;
}

bool ServoServer::ServeC(Socket client) {
  const int fd = client.fd();
  while (!stop_) {
    char buf[32];
    const int64_t got = RecvSome(fd, buf, sizeof(buf), kServerPollStep);  // read(sockfd, buffer, 32)
    if (got == -1) continue;
    if (got <= 0) {
      // read() gives 0 at the client's close; MRSsocket.c then sets the same servos again and
      // replies into the closed socket: SIGPIPE ends the process.
      Exit(
          "the client left; MRSsocket.c's next reply hits the closed socket and SIGPIPE (broken pipe) "
          "kills it: one client per launch");
      return true;
    }
    const std::string bytes(buf, size_t(got));
    if (on_raw_) on_raw_(bytes);
    const CServerScan scan = ScanLikeCServer(bytes, &c_globals_);
    if (scan.num_fields < models::kNumServos) {
      Count(&ServoServerStats::num_malformed);
      if (options_.log) {
        options_.log("c servo server: " + std::to_string(scan.num_fields) + " of 5 fields parsed from " +
                     PythonRepr(bytes) + "; the others keep their previous values");
      }
    }
    const ClampResult clamped = guard_.Clamp(c_globals_);
    c_globals_ = clamped.pwm_us;  // MRSsocket.c clamps its globals in place
    if (scan.data < 0) {
      if (scan.data == -2) {
        Exit("the client sent -2: MRSsocket.c stops");
        return true;
      }
      if (options_.log) options_.log("c servo server: the client sent a negative first field: session closed");
      return false;
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++stats_.num_packets;
      if (clamped.any_clamped) ++stats_.num_clamped;
    }
    if (on_packet_) on_packet_(clamped.pwm_us);
    SendAll(fd, std::to_string(scan.data) + "\n\r");  // sendData(newsockfd, data): "%d\n\r"
  }
  return true;
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
  auto last_activity = partial_since;
  while (!stop_) {
    const int64_t got = RecvSome(fd, buf, sizeof(buf), kServerPollStep);
    if (got == -1) {  // no data yet: keep waiting, unless a partial packet went stale
      const auto now = std::chrono::steady_clock::now();
      if (assembler.Pending() > 0 && now - partial_since > options_.partial_timeout) {
        break;
      }
      if (now - last_activity > options_.idle_timeout && WaitReadable(listener_.fd(), std::chrono::milliseconds(0))) {
        Count(&ServoServerStats::num_idle_closed);
        if (options_.log) {
          options_.log("servo server: closing a session silent for " + std::to_string(options_.idle_timeout.count()) +
                       " ms: another client is waiting");
        }
        return;
      }
      continue;
    }
    last_activity = std::chrono::steady_clock::now();
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
