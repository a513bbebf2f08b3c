#pragma once
// Small POSIX TCP helpers shared by the robot link's clients and loopback servers (IPv4; an
// IPv6 literal such as "::1" or "[::1]" also works for Listen and ConnectTcp).
// All functions throw std::runtime_error naming the address and the errno text on failure,
// except where a return value says otherwise. Sockets are plain fds wrapped in Socket (RAII).
#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>

namespace owlcal::robot {

// Owns one file descriptor; closes it on destruction. Movable, not copyable.
class Socket {
 public:
  Socket() = default;
  explicit Socket(int fd) : fd_(fd) {}
  ~Socket() { Close(); }
  Socket(Socket&& o) noexcept : fd_(o.Release()) {}
  Socket& operator=(Socket&& o) noexcept {
    if (this != &o) {
      Close();
      fd_ = o.Release();
    }
    return *this;
  }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;

  int fd() const { return fd_; }
  bool valid() const { return fd_ >= 0; }
  int Release() {
    const int f = fd_;
    fd_ = -1;
    return f;
  }
  void Close();
  // shutdown(SHUT_RDWR): wakes a thread blocked on this socket.
  void Shutdown();

 private:
  int fd_ = -1;
};

// True for a loopback address: "localhost", 127.0.0.0/8, ::1 (also "[::1]") and ::ffff:127.x.
bool IsLoopbackAddress(const std::string& address);

// A listening socket bound to address:port (port 0 = ephemeral); *bound_port gets the port.
Socket Listen(const std::string& address, int port, int* bound_port, int backlog = 8);

// Connects with a timeout. Throws on refusal, unreachable or timeout ("127.0.0.1:12345: ...").
// `host` is a dotted IPv4 address or a name resolved with getaddrinfo.
Socket ConnectTcp(const std::string& host, int port, std::chrono::milliseconds timeout);

// Waits until fd is readable (or has EOF/error). false on timeout.
bool WaitReadable(int fd, std::chrono::milliseconds timeout);

// Reads up to n bytes (one recv), waiting at most `timeout`. Returns bytes read, 0 on EOF,
// -1 on timeout, -2 on error.
int64_t RecvSome(int fd, char* buf, int64_t n, std::chrono::milliseconds timeout);

// Writes all bytes (MSG_NOSIGNAL: a closed peer gives false, never SIGPIPE).
bool SendAll(int fd, std::string_view bytes);

// HOST[:PORT] -> host and port (default_port when no port is given). Accepts "10.0.0.10",
// "localhost:12345", "[::1]:80" is not supported (IPv4 only). Throws std::invalid_argument
// naming the text for an empty host or a port that is not 1..65535.
struct HostPort {
  std::string host;
  int port = 0;
  std::string ToString() const { return host + ":" + std::to_string(port); }
};
HostPort ParseHostPort(const std::string& text, int default_port);

}  // namespace owlcal::robot
