#include "robot/mjpeg_server.h"

#include <linux/sockios.h>  // SIOCOUTQ
#include <linux/tcp.h>      // struct tcp_info with tcpi_snd_wnd (glibc's is older)
#include <netinet/in.h>
#include <sys/ioctl.h>
#include <sys/socket.h>

#include <algorithm>
#include <cctype>
#include <cstddef>
#include <stdexcept>
#include <thread>

namespace owlcal::robot {
namespace {

constexpr std::chrono::milliseconds kPollStep{50};
constexpr size_t kMaxHeaderBytes = 64 * 1024;
constexpr size_t kMaxBodyBytes = 16 * 1024 * 1024;

std::string LowerAscii(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

const char* StatusText(int status) {
  switch (status) {
    case 200:
      return "OK";
    case 201:
      return "Created";
    case 204:
      return "No Content";
    case 400:
      return "Bad Request";
    case 404:
      return "Not Found";
    case 405:
      return "Method Not Allowed";
    case 409:
      return "Conflict";
    case 500:
      return "Internal Server Error";
    default:
      return "Status";
  }
}

bool IsToken(const std::string& s) {
  if (s.empty() || s.size() > 32) return false;
  for (unsigned char c : s) {
    if (!std::isupper(c)) return false;
  }
  return true;
}

// Reads one request (headers + Content-Length body). nullopt on EOF, timeout or garbage; for
// garbage *bad says why (the caller answers 400), for EOF or an idle timeout it stays empty.
std::optional<HttpRequest> ReadRequest(int fd,
                                       const std::atomic<bool>& stop,
                                       std::chrono::milliseconds timeout,
                                       std::string* bad) {
  std::string data;
  char buf[4096];
  size_t header_end = std::string::npos;
  const int64_t max_idle_steps = std::max<int64_t>(1, timeout.count() / kPollStep.count());
  int64_t idle_steps = 0;
  while (header_end == std::string::npos) {
    if (data.size() > kMaxHeaderBytes) {
      *bad = "request headers longer than " + std::to_string(kMaxHeaderBytes) + " bytes";
      return std::nullopt;
    }
    if (stop || idle_steps > max_idle_steps) return std::nullopt;
    const int64_t got = RecvSome(fd, buf, sizeof(buf), kPollStep);
    if (got == -1) {
      ++idle_steps;
      continue;
    }
    if (got <= 0) return std::nullopt;
    idle_steps = 0;
    data.append(buf, static_cast<size_t>(got));
    header_end = data.find("\r\n\r\n");
  }
  HttpRequest req;
  const std::string head = data.substr(0, header_end);
  std::string body = data.substr(header_end + 4);
  size_t line_end = head.find("\r\n");
  const std::string request_line = head.substr(0, line_end);
  const size_t sp1 = request_line.find(' ');
  const size_t sp2 = request_line.find(' ', sp1 + 1);
  req.method = request_line.substr(0, sp1 == std::string::npos ? 0 : sp1);
  std::string target = sp1 == std::string::npos
                           ? std::string()
                           : request_line.substr(sp1 + 1, sp2 == std::string::npos ? std::string::npos : sp2 - sp1 - 1);
  const std::string version = sp2 == std::string::npos ? std::string() : request_line.substr(sp2 + 1);
  if (!IsToken(req.method) || target.empty() || target[0] != '/' || version.rfind("HTTP/", 0) != 0) {
    std::string shown;
    for (unsigned char ch : request_line.substr(0, 60)) shown += std::isprint(ch) ? char(ch) : '?';
    *bad = "not an HTTP request line (expected 'METHOD /path HTTP/1.x'): '" + shown + "'";
    return std::nullopt;
  }
  const size_t q = target.find('?');
  req.path = target.substr(0, q);
  if (q != std::string::npos) req.query = target.substr(q + 1);
  while (line_end != std::string::npos) {
    const size_t start = line_end + 2;
    line_end = head.find("\r\n", start);
    const std::string line = head.substr(start, line_end == std::string::npos ? std::string::npos : line_end - start);
    const size_t colon = line.find(':');
    if (colon != std::string::npos) req.headers[LowerAscii(Trim(line.substr(0, colon)))] = Trim(line.substr(colon + 1));
  }
  size_t length = 0;
  if (auto it = req.headers.find("content-length"); it != req.headers.end()) {
    const std::string& v = it->second;
    if (v.empty() || v.size() > 12 || v.find_first_not_of("0123456789") != std::string::npos) {
      *bad = "Content-Length '" + v.substr(0, 20) + "' is not a number";
      return std::nullopt;
    }
    length = std::stoul(v);
  }
  if (length > kMaxBodyBytes) {
    *bad = "body of " + std::to_string(length) + " bytes is over " + std::to_string(kMaxBodyBytes);
    return std::nullopt;
  }
  idle_steps = 0;
  while (body.size() < length) {
    if (stop || idle_steps > max_idle_steps) return std::nullopt;
    const int64_t got = RecvSome(fd, buf, static_cast<int64_t>(std::min(sizeof(buf), length - body.size())), kPollStep);
    if (got == -1) {
      ++idle_steps;
      continue;
    }
    if (got <= 0) return std::nullopt;
    body.append(buf, static_cast<size_t>(got));
  }
  body.resize(length);
  req.body = std::move(body);
  return req;
}

void SendResponse(int fd, const HttpResponse& r) {
  std::string out = "HTTP/1.0 " + std::to_string(r.status) + " " + StatusText(r.status) + "\r\n";
  out += "Content-Type: " + r.content_type + "\r\n";
  out += "Content-Length: " + std::to_string(r.body.size()) + "\r\n";
  out += "Connection: close\r\n";
  for (const auto& [k, v] : r.headers) out += k + ": " + v + "\r\n";
  out += "\r\n";
  out += r.body;
  SendAll(fd, out);
}

bool PeerClosed(int fd) {
  char c;
  return WaitReadable(fd, std::chrono::milliseconds(0)) && ::recv(fd, &c, 1, MSG_DONTWAIT | MSG_PEEK) == 0;
}

// The peer's advertised receive window [bytes] (Linux TCP_INFO tcpi_snd_wnd, kernel 6.x), or -1
// when the kernel does not report it.
int64_t PeerWindowBytes(int fd) {
  struct tcp_info info {};
  socklen_t len = sizeof(info);
  if (::getsockopt(fd, IPPROTO_TCP, TCP_INFO, &info, &len) != 0) return -1;
  if (len < offsetof(struct tcp_info, tcpi_snd_wnd) + sizeof(info.tcpi_snd_wnd)) return -1;
  return info.tcpi_snd_wnd;
}

// Bytes written to fd that the peer has not acknowledged yet (SIOCOUTQ), or -1.
int64_t UnackedBytes(int fd) {
  int bytes = 0;
  if (::ioctl(fd, SIOCOUTQ, &bytes) != 0) return -1;
  return bytes;
}

// Decides when a stream client is ready for the next frame (mjpg-streamer's model: the newest
// frame whenever the client can take one) and so bounds the old frames the kernel holds for it.
// A frame is written only once
//   1. everything written before is acknowledged (SIOCOUTQ = 0): the small send buffer
//      (MjpegServerOptions::send_buffer_bytes) never holds a frame waiting for a slow client;
//   2. the client's advertised window is back within the slack of the largest it has
//      advertised, i.e. it has read what it was sent; Linux autotunes a slow client's receive
//      buffer to megabytes, which would otherwise hold dozens of old frames.
// A Linux receiver announces a window that its reading reopened only if the window had fallen
// below half its buffer, so with a large buffer the server would never hear of the read (it
// used to wait for a fallback timeout, and a client working 30-60 ms per frame stalled). So while it waits
// the server sends the next part's constant first bytes ("--BOUNDARY\r\nContent-Type:
// image/jpeg\r\n"), one at a time, each once the previous is acknowledged and at most every
// max(kMinProbeGap, a quarter of the wait so far, up to kMaxProbeGap): every byte's ACK carries
// the current window. When those bytes run out (a client paused for about 6 s) the newest frame
// is sent anyway and the window of that moment becomes the reference (a client whose buffer
// shrank is not stalled for ever).
// Old frames therefore sit only in the client's receive buffer: the one frame sent after its
// last read, plus one more per 6 s or more that it stays paused (and, in the first seconds of a
// connection, while the client's kernel grows the window as data arrives, possibly one more).
class ClientPacer {
 public:
  explicit ClientPacer(std::string prefix) : prefix_(std::move(prefix)) {}

  // Waits until the client may be sent a frame; false when it left or the server stops.
  bool WaitReady(int fd, const std::atomic<bool>& stop) {
    const auto start = std::chrono::steady_clock::now();
    auto last_probe = start;
    while (!stop) {
      const int64_t unacked = UnackedBytes(fd);
      const int64_t window = PeerWindowBytes(fd);
      if (unacked < 0 || window < 0) return true;  // no TCP information: no pacing
      if (unacked == 0) {
        max_window_ = std::max(max_window_, window);
        if (max_window_ - window <= Slack()) return true;
        const auto now = std::chrono::steady_clock::now();
        const auto gap = std::clamp<std::chrono::steady_clock::duration>((now - start) / 4, kMinProbeGap, kMaxProbeGap);
        if (now - last_probe >= gap) {
          if (probe_bytes_sent_ == prefix_.size()) {
            max_window_ = window;
            return true;
          }
          if (::send(fd, prefix_.data() + probe_bytes_sent_, 1, MSG_NOSIGNAL | MSG_DONTWAIT) != 1) return false;
          ++probe_bytes_sent_;
          last_probe = now;
        }
      }
      if (PeerClosed(fd)) return false;
      std::this_thread::sleep_for(kPollGap);
    }
    return false;
  }

  // The part's bytes that WaitReady has not sent yet; resets for the next part.
  std::string TakeRestOfPrefix(size_t part_bytes) {
    std::string rest = prefix_.substr(probe_bytes_sent_);
    probe_bytes_sent_ = 0;
    last_part_bytes_ = static_cast<int64_t>(part_bytes);
    return rest;
  }

 private:
  static constexpr std::chrono::milliseconds kPollGap{1};
  static constexpr std::chrono::milliseconds kMinProbeGap{2};
  static constexpr std::chrono::milliseconds kMaxProbeGap{250};
  // Unread bytes still counted as "read everything" [bytes]: half a frame, at most 32 KiB, at
  // least 4 KiB (the window's scale granularity and the probe bytes).
  int64_t Slack() const { return std::clamp<int64_t>(last_part_bytes_ / 2, 4096, 32 * 1024); }

  std::string prefix_;
  size_t probe_bytes_sent_ = 0;
  int64_t max_window_ = 0;
  int64_t last_part_bytes_ = 0;
};

int64_t SteadyUs() {
  return std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

bool MjpegServerOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "mjpeg server: " + m;
    return false;
  };
  if (port < 0 || port > 65535) return fail("port = " + std::to_string(port) + " is not 0..65535");
  if (send_buffer_bytes < 0) return fail("send_buffer_bytes = " + std::to_string(send_buffer_bytes) + " is negative");
  if (request_timeout.count() <= 0) return fail("request_timeout must be positive");
  if (!(fps > 0 && fps <= 1000)) return fail("fps = " + std::to_string(fps) + " is not in (0, 1000]");
  if (boundary.empty() || boundary.size() > 70) return fail("boundary must be 1..70 characters");
  if (stream_path.empty() || stream_path[0] != '/') return fail("stream_path '" + stream_path + "' must start with /");
  return true;
}

MjpegServer::MjpegServer(MjpegServerOptions options, FrameSource source, RouteHandler routes)
    : options_(std::move(options)), source_(std::move(source)), routes_(std::move(routes)) {}

MjpegServer::~MjpegServer() { Stop(); }

void MjpegServer::Start() {
  if (started_) return;
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument(why);
  listener_ = Listen(options_.bind_address, options_.port, &port_, 16);
  stop_ = false;
  started_ = true;
  accept_thread_ = std::thread([this] { AcceptLoop(); });
  if (source_) source_thread_ = std::thread([this] { SourceLoop(); });
}

void MjpegServer::Stop() {
  if (!started_) return;
  stop_ = true;
  frame_cv_.notify_all();
  if (accept_thread_.joinable()) accept_thread_.join();
  if (source_thread_.joinable()) source_thread_.join();
  std::vector<std::unique_ptr<Client>> clients;
  {
    std::lock_guard<std::mutex> lock(clients_mutex_);
    clients.swap(clients_);
  }
  for (auto& c : clients) c->socket.Shutdown();
  frame_cv_.notify_all();
  for (auto& c : clients) {
    if (c->thread.joinable()) c->thread.join();
  }
  listener_.Close();
  started_ = false;
}

void MjpegServer::Publish(std::vector<uint8_t> jpeg, std::optional<int64_t> capture_stamp_us) {
  {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    frame_ = std::make_shared<const std::vector<uint8_t>>(std::move(jpeg));
    ++frame_seq_;
    frame_stamp_us_ = capture_stamp_us ? *capture_stamp_us : SteadyUs();
  }
  frame_cv_.notify_all();
}

int64_t MjpegServer::NumFramesPublished() const {
  std::lock_guard<std::mutex> lock(frame_mutex_);
  return frame_seq_;
}

bool MjpegServer::WaitForStreamClients(int n, std::chrono::milliseconds timeout) const {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (num_stream_clients_.load() >= n) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return num_stream_clients_.load() >= n;
}

void MjpegServer::SourceLoop() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(1.0 / options_.fps));
  auto next = std::chrono::steady_clock::now();
  while (!stop_) {
    if (std::optional<std::vector<uint8_t>> jpeg = source_()) Publish(std::move(*jpeg));
    next += period;
    const auto now = std::chrono::steady_clock::now();
    if (next < now) next = now;  // fell behind: do not burst
    // Sleep in short steps so Stop() is prompt.
    while (!stop_ && std::chrono::steady_clock::now() < next) {
      std::this_thread::sleep_for(
          std::min<std::chrono::steady_clock::duration>(next - std::chrono::steady_clock::now(), kPollStep));
    }
  }
}

void MjpegServer::AcceptLoop() {
  while (!stop_) {
    if (!WaitReadable(listener_.fd(), kPollStep)) continue;
    const int fd = ::accept4(listener_.fd(), nullptr, nullptr, SOCK_CLOEXEC);
    if (fd < 0) continue;
    std::lock_guard<std::mutex> lock(clients_mutex_);
    // Reap finished clients.
    for (auto it = clients_.begin(); it != clients_.end();) {
      if ((*it)->done) {
        if ((*it)->thread.joinable()) (*it)->thread.join();
        it = clients_.erase(it);
      } else {
        ++it;
      }
    }
    auto client = std::make_unique<Client>();
    client->socket = Socket(fd);
    Client* raw = client.get();
    client->thread = std::thread([this, raw] { ServeClient(raw); });
    clients_.push_back(std::move(client));
  }
}

void MjpegServer::ServeClient(Client* client) {
  const int fd = client->socket.fd();
  std::string bad;
  std::optional<HttpRequest> req = ReadRequest(fd, stop_, options_.request_timeout, &bad);
  if (!req && !bad.empty()) {
    if (options_.log) options_.log("http server: 400 for a client: " + bad);
    SendResponse(fd, HttpResponse{400, "text/plain", "bad request: " + bad + "\n", {}});
  }
  if (req) {
    if (req->method == "GET" && req->path == options_.stream_path) {
      Stream(fd);
    } else {
      std::optional<HttpResponse> resp;
      if (routes_) {
        try {
          resp = routes_(*req);
        } catch (const std::exception& e) {
          resp = HttpResponse{500, "text/plain", std::string(e.what()) + "\n", {}};
        }
      }
      if (!resp) resp = HttpResponse{404, "text/plain", "not found: " + req->path + "\n", {}};
      SendResponse(fd, *resp);
    }
  }
  client->socket.Shutdown();
  client->done = true;
}

void MjpegServer::Stream(int fd) {
  const std::string header =
      "HTTP/1.0 200 OK\r\n"
      "Connection: close\r\n"
      "Server: owlcal-mjpeg\r\n"
      "Cache-Control: no-store, no-cache, must-revalidate, pre-check=0, post-check=0, max-age=0\r\n"
      "Pragma: no-cache\r\n"
      "Content-Type: multipart/x-mixed-replace;boundary=" +
      options_.boundary + "\r\n\r\n";
  if (options_.send_buffer_bytes > 0) {
    // Bound what can queue for a slow client (see the header); Linux doubles the value.
    const int bytes = options_.send_buffer_bytes;
    ::setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof(bytes));
  }
  // A frame's last segment and the pacer's one-byte probes leave at once (Nagle would hold them
  // for the ACK of what went before).
  const int one = 1;
  ::setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  if (!SendAll(fd, header)) return;
  num_stream_clients_.fetch_add(1);
  if (options_.log) options_.log("mjpeg server: stream client connected");
  int64_t last_seq;
  {
    std::lock_guard<std::mutex> lock(frame_mutex_);
    last_seq = frame_seq_;  // start with the next frame
  }
  ClientPacer pacer("--" + options_.boundary + "\r\nContent-Type: image/jpeg\r\n");
  while (!stop_) {
    // Wait until the client has read what it was sent (ClientPacer) and for a frame it has not
    // had, then send the newest (those published meanwhile are dropped for this client).
    if (!pacer.WaitReady(fd, stop_)) break;
    std::shared_ptr<const std::vector<uint8_t>> frame;
    int64_t stamp_us;
    {
      std::unique_lock<std::mutex> lock(frame_mutex_);
      frame_cv_.wait_for(lock, kPollStep, [&] { return stop_ || frame_seq_ > last_seq; });
      if (stop_) break;
      if (frame_seq_ <= last_seq) {
        // Idle: detect a client that went away (readable with EOF).
        lock.unlock();
        if (PeerClosed(fd)) break;
        continue;
      }
      frame = frame_;
      last_seq = frame_seq_;
      stamp_us = frame_stamp_us_;
    }
    std::string part;
    if (options_.send_content_length) part += "Content-Length: " + std::to_string(frame->size()) + "\r\n";
    char ts[64];
    std::snprintf(ts,
                  sizeof(ts),
                  "X-Timestamp: %lld.%06lld\r\n\r\n",
                  static_cast<long long>(stamp_us / 1000000),
                  static_cast<long long>(stamp_us % 1000000));
    part += ts;
    part.append(reinterpret_cast<const char*>(frame->data()), frame->size());
    part += "\r\n";
    part.insert(0, pacer.TakeRestOfPrefix(part.size()));
    if (!SendAll(fd, part)) break;
    num_frames_sent_.fetch_add(1);
  }
  num_stream_clients_.fetch_sub(1);
  if (options_.log) options_.log("mjpeg server: stream client left");
}

}  // namespace owlcal::robot
