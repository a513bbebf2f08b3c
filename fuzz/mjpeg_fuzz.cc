// The MJPEG stream parser on hostile bytes: the input is what a server sends (HTTP response
// head, multipart parts, JPEGs), fed through a socketpair to MjpegClient. Frames are checked
// against a 1280x480 robot before decoding; nothing may crash, hang or allocate without bound.
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>

#include "fuzz/fuzz_util.h"
#include "robot/mjpeg_client.h"
#include "robot/socket_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace owlcal;
  if (size > 200000) return 0;  // must fit the socket buffer (written before it is read)
  (void)robot::JpegDeclaredSize(data, size);
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) return 0;
  const int buffer = 1 << 20;
  ::setsockopt(fds[1], SOL_SOCKET, SO_SNDBUF, &buffer, sizeof(buffer));
  ::setsockopt(fds[0], SOL_SOCKET, SO_RCVBUF, &buffer, sizeof(buffer));
  robot::Socket reader(fds[0]);
  {
    robot::Socket writer(fds[1]);
    robot::SendAll(writer.fd(), fuzz::Text(data, size));
  }  // closed: the client reads to EOF and stops
  robot::MjpegClientOptions o;
  o.host = "127.0.0.1";
  o.port = 1;  // never connected: reconnect is off
  o.reconnect = false;
  o.read_timeout = std::chrono::milliseconds(50);
  o.expected_width = 1280;
  o.expected_height = 480;
  o.max_frame_bytes = 1 << 20;
  robot::MjpegClient client(o);
  if (!client.Adopt(std::move(reader), std::chrono::milliseconds(100))) return 0;
  for (int i = 0; i < 64; ++i) {
    const std::optional<robot::MjpegFrame> f = client.Next(std::chrono::milliseconds(100));
    if (!f) break;
    OWLCAL_FUZZ_ASSERT(f->stereo.left.cols == 640 && f->stereo.left.rows == 480);
  }
  return 0;
}
