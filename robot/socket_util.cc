#include "robot/socket_util.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>
#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace owlcal::robot {
namespace {

std::string Errno() { return std::strerror(errno); }

// An IPv4 or IPv6 socket address.
struct Address {
  sockaddr_storage storage{};
  socklen_t length = 0;
  int family = AF_INET;
  sockaddr* get() { return reinterpret_cast<sockaddr*>(&storage); }
};

// An IPv6 literal ("::1", or "[::1]") as a socket address; false for anything else.
bool ResolveIpv6Literal(const std::string& host, int port, Address* out) {
  std::string h = host;
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  sockaddr_in6 a6{};
  a6.sin6_family = AF_INET6;
  a6.sin6_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET6, h.c_str(), &a6.sin6_addr) != 1) return false;
  std::memcpy(&out->storage, &a6, sizeof(a6));
  out->length = sizeof(a6);
  out->family = AF_INET6;
  return true;
}

sockaddr_in Resolve(const std::string& host, int port);

// IPv6 literals as IPv6, everything else as Resolve (IPv4 literal or name).
Address ResolveAny(const std::string& host, int port) {
  Address a;
  if (ResolveIpv6Literal(host, port, &a)) return a;
  const sockaddr_in a4 = Resolve(host, port);
  std::memcpy(&a.storage, &a4, sizeof(a4));
  a.length = sizeof(a4);
  a.family = AF_INET;
  return a;
}

sockaddr_in Resolve(const std::string& host, int port) {
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &addr.sin_addr) == 1) return addr;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* res = nullptr;
  const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &res);
  if (rc != 0 || res == nullptr) {
    throw std::runtime_error(host + ":" + std::to_string(port) + ": cannot resolve host (" + gai_strerror(rc) + ")");
  }
  addr.sin_addr = reinterpret_cast<sockaddr_in*>(res->ai_addr)->sin_addr;
  freeaddrinfo(res);
  return addr;
}

}  // namespace

void Socket::Close() {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
}

void Socket::Shutdown() {
  if (fd_ >= 0) ::shutdown(fd_, SHUT_RDWR);
}

Socket Listen(const std::string& address, int port, int* bound_port, int backlog) {
  const std::string where = address + ":" + std::to_string(port);
  if (port < 0 || port > 65535) throw std::invalid_argument(where + ": port out of range");
  Address addr = ResolveAny(address, port);
  Socket s(::socket(addr.family, SOCK_STREAM | SOCK_CLOEXEC, 0));
  if (!s.valid()) throw std::runtime_error(where + ": socket() failed: " + Errno());
  const int one = 1;
  ::setsockopt(s.fd(), SOL_SOCKET, SO_REUSEADDR, &one, sizeof(one));
  if (addr.family == AF_INET6) ::setsockopt(s.fd(), IPPROTO_IPV6, IPV6_V6ONLY, &one, sizeof(one));
  if (::bind(s.fd(), addr.get(), addr.length) != 0) {
    throw std::runtime_error(where + ": bind failed: " + Errno());
  }
  if (::listen(s.fd(), backlog) != 0) throw std::runtime_error(where + ": listen failed: " + Errno());
  socklen_t len = sizeof(addr.storage);
  ::getsockname(s.fd(), addr.get(), &len);
  if (bound_port) {
    *bound_port = addr.family == AF_INET6 ? ntohs(reinterpret_cast<sockaddr_in6*>(addr.get())->sin6_port)
                                          : ntohs(reinterpret_cast<sockaddr_in*>(addr.get())->sin_port);
  }
  return s;
}

Socket ConnectTcp(const std::string& host, int port, std::chrono::milliseconds timeout) {
  const std::string where = host + ":" + std::to_string(port);
  Address addr = ResolveAny(host, port);
  Socket s(::socket(addr.family, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0));
  if (!s.valid()) throw std::runtime_error(where + ": socket() failed: " + Errno());
  int rc = ::connect(s.fd(), addr.get(), addr.length);
  if (rc != 0 && errno != EINPROGRESS) throw std::runtime_error(where + ": connect failed: " + Errno());
  if (rc != 0) {
    pollfd p{s.fd(), POLLOUT, 0};
    rc = ::poll(&p, 1, static_cast<int>(timeout.count()));
    if (rc == 0) {
      throw std::runtime_error(where + ": connect timed out after " + std::to_string(timeout.count()) + " ms");
    }
    int err = 0;
    socklen_t len = sizeof(err);
    ::getsockopt(s.fd(), SOL_SOCKET, SO_ERROR, &err, &len);
    if (rc < 0 || err != 0) {
      throw std::runtime_error(where + ": connect failed: " + std::strerror(err ? err : errno));
    }
  }
  // Back to blocking mode; reads use poll with timeouts.
  ::fcntl(s.fd(), F_SETFL, ::fcntl(s.fd(), F_GETFL) & ~O_NONBLOCK);
  const int one = 1;
  ::setsockopt(s.fd(), IPPROTO_TCP, TCP_NODELAY, &one, sizeof(one));
  return s;
}

bool WaitReadable(int fd, std::chrono::milliseconds timeout) {
  pollfd p{fd, POLLIN, 0};
  int rc;
  do {
    rc = ::poll(&p, 1, static_cast<int>(timeout.count()));
  } while (rc < 0 && errno == EINTR);
  return rc > 0;
}

int64_t RecvSome(int fd, char* buf, int64_t n, std::chrono::milliseconds timeout) {
  if (!WaitReadable(fd, timeout)) return -1;
  ssize_t got;
  do {
    got = ::recv(fd, buf, static_cast<size_t>(n), 0);
  } while (got < 0 && errno == EINTR);
  if (got < 0) return -2;
  return got;
}

bool SendAll(int fd, std::string_view bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::send(fd, bytes.data() + done, bytes.size() - done, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

HostPort ParseHostPort(const std::string& text, int default_port) {
  HostPort hp;
  const size_t colon = text.rfind(':');
  hp.host = text.substr(0, colon);
  hp.port = default_port;
  if (colon != std::string::npos) {
    const std::string port_text = text.substr(colon + 1);
    int port = -1;
    if (!port_text.empty() && port_text.size() <= 5 && port_text.find_first_not_of("0123456789") == std::string::npos) {
      port = std::stoi(port_text);
    }
    if (port < 1 || port > 65535) {
      throw std::invalid_argument("robot address '" + text + "': port '" + port_text + "' is not 1..65535");
    }
    hp.port = port;
  }
  if (hp.host.empty()) throw std::invalid_argument("robot address '" + text + "': empty host");
  return hp;
}

bool IsLoopbackAddress(const std::string& address) {
  if (address == "localhost") return true;
  std::string h = address;
  if (h.size() >= 2 && h.front() == '[' && h.back() == ']') h = h.substr(1, h.size() - 2);
  in_addr a4{};
  if (inet_pton(AF_INET, h.c_str(), &a4) == 1) return (ntohl(a4.s_addr) >> 24) == 127;  // 127.0.0.0/8
  in6_addr a6{};
  if (inet_pton(AF_INET6, h.c_str(), &a6) == 1) {
    if (IN6_IS_ADDR_LOOPBACK(&a6)) return true;
    return IN6_IS_ADDR_V4MAPPED(&a6) && a6.s6_addr[12] == 127;  // ::ffff:127.x.y.z
  }
  return false;
}

}  // namespace owlcal::robot
