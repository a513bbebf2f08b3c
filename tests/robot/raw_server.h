#pragma once
// A hostile loopback TCP server for tests: accepts every connection on 127.0.0.1, reads what
// the client sends (up to `read_bytes`, or until a blank line for HTTP) and answers with
// `reply(connection_index)`, then closes (or keeps the connection open if keep_open).
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <functional>
#include <string>
#include <thread>

#include "robot/socket_util.h"

namespace owlcal::robot::testing {

class RawServer {
 public:
  RawServer(std::function<std::string(int)> reply, size_t read_bytes, bool keep_open = false)
      : reply_(std::move(reply)), read_bytes_(read_bytes), keep_open_(keep_open) {
    listen_ = Listen("127.0.0.1", 0, &port_);
    thread_ = std::thread([this] { Loop(); });
  }
  ~RawServer() {
    stop_ = true;
    thread_.join();
  }
  int Port() const { return port_; }
  int NumAccepted() const { return accepted_.load(); }

 private:
  void Loop() {
    std::vector<int> open;
    while (!stop_) {
      pollfd p{listen_.fd(), POLLIN, 0};
      if (::poll(&p, 1, 10) <= 0) continue;
      const int fd = ::accept(listen_.fd(), nullptr, nullptr);
      if (fd < 0) continue;
      const int index = accepted_++;
      std::string got;
      char buf[4096];
      while (got.size() < read_bytes_ && got.find("\r\n\r\n") == std::string::npos) {
        const int64_t n = RecvSome(fd, buf, sizeof(buf), std::chrono::milliseconds(500));
        if (n <= 0) break;
        got.append(buf, static_cast<size_t>(n));
      }
      SendAll(fd, reply_(index));
      if (keep_open_) {
        open.push_back(fd);
      } else {
        ::shutdown(fd, SHUT_RDWR);
        ::close(fd);
      }
    }
    for (int fd : open) ::close(fd);
  }

  std::function<std::string(int)> reply_;
  size_t read_bytes_;
  bool keep_open_;
  Socket listen_;
  int port_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<int> accepted_{0};
};

}  // namespace owlcal::robot::testing
