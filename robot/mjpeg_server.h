#pragma once
// A reusable loopback HTTP server that streams MJPEG like the Owl's camera server
// (http://HOST:8080/stream/video.mjpeg), for tests and for the virtual Owl's served mode.
//
// GET <stream_path> (default /stream/video.mjpeg) answers
//   HTTP/1.0 200 OK
//   Content-Type: multipart/x-mixed-replace;boundary=<boundary>
// then, per frame, the mjpg-streamer part layout:
//   --<boundary>\r\n
//   Content-Type: image/jpeg\r\n
//   Content-Length: <n>\r\n        (left out when options.send_content_length is false)
//   X-Timestamp: <sec>.<usec>\r\n  (steady clock: the capture time given to Publish, else when
//                                  the frame was published; mjpg-streamer sends the capture time)
//   \r\n<jpeg bytes>\r\n
// Frames come either from a FrameSource polled at options.fps on a server thread (nullopt =
// no frame this tick), or from Publish(jpeg) (push API). One thread per client; any number of
// clients.
//
// Slow clients (as mjpg-streamer, the Owl's streamer): each client is sent the NEWEST frame
// whenever it is ready for one; the frames published while it was busy are dropped for it, never
// queued. "Ready" means the client has read what it was sent: a frame is written only once the
// previous one is fully acknowledged and the client's advertised TCP window shows it has been
// read (the server sends the next part's constant first bytes one at a time, each ACK carrying
// the window, because Linux does not announce a window a read reopened). The stream socket's send
// buffer is options.send_buffer_bytes (the kernel doubles it; 0 leaves Linux's autotuning).
// Where old frames can still sit: only in the client's receive buffer, the one frame sent after
// its last read, plus one more per 6 s or more that it stays paused (robot/mjpeg_server.cc,
// ClientPacer). So a client that reads one frame per period P gets frames about P + latency old,
// and after a pause its second frame is fresh.
//
// Other routes: any request that is not a GET of the stream path goes to the RouteHandler
// (e.g. GET /truth, PUT /scene/targets/NAME with a JSON body); nullopt from it, or no
// handler, gives 404. Those responses close the connection (HTTP/1.0 style). A request that
// is not HTTP (no "METHOD /path HTTP/x" line, a bad Content-Length, headers over 64 KiB or a
// body over 16 MiB) gets 400 naming what was wrong. Idle timeout: a client that has not sent a
// complete request within options.request_timeout (5 s) is disconnected, so a silent client
// holds nothing but its own thread.
//
// Usage:
//   MjpegServer server({}, [&] { return std::optional(next_jpeg()); });
//   server.Start();
//   // cv::VideoCapture cap("http://127.0.0.1:" + std::to_string(server.Port()) + "/stream/video.mjpeg");
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "robot/limits_guard.h"  // LogSink
#include "robot/socket_util.h"

namespace owlcal::robot {

struct HttpRequest {
  std::string method;                          // "GET", "PUT", ...
  std::string path;                            // "/truth" (without the query)
  std::string query;                           // text after '?', or ""
  std::map<std::string, std::string> headers;  // names lower-cased
  std::string body;                            // Content-Length bytes
};

struct HttpResponse {
  int status = 200;
  std::string content_type = "text/plain";
  std::string body;
  std::map<std::string, std::string> headers;  // extra headers
};

struct MjpegServerOptions {
  std::string bind_address = "127.0.0.1";
  int port = 0;  // 0 = ephemeral; Port() tells
  std::string stream_path = "/stream/video.mjpeg";
  std::string boundary = "boundarydonotcross";  // as mjpg-streamer
  double fps = 30.0;                            // FrameSource polling rate [Hz]
  bool send_content_length = true;
  int send_buffer_bytes = 64 * 1024;                // SO_SNDBUF of a stream socket; 0 = kernel autotuning
  std::chrono::milliseconds request_timeout{5000};  // idle timeout for the request (headers and body)
  LogSink log;
  bool Check(std::string* why) const;
};

class MjpegServer {
 public:
  using FrameSource = std::function<std::optional<std::vector<uint8_t>>()>;
  using RouteHandler = std::function<std::optional<HttpResponse>(const HttpRequest&)>;

  explicit MjpegServer(MjpegServerOptions options, FrameSource source = nullptr, RouteHandler routes = nullptr);
  ~MjpegServer();
  MjpegServer(const MjpegServer&) = delete;
  MjpegServer& operator=(const MjpegServer&) = delete;

  // Binds and starts. Throws naming address:port if binding fails.
  void Start();
  // Closes every client and joins all threads. Idempotent.
  void Stop();
  int Port() const { return port_; }

  // Push API: makes `jpeg` the newest frame; clients receive it at most once (a busy client
  // skips it). capture_stamp_us: when the frame was captured (steady clock, us), sent as
  // X-Timestamp; default: now.
  void Publish(std::vector<uint8_t> jpeg, std::optional<int64_t> capture_stamp_us = std::nullopt);
  int NumStreamClients() const { return num_stream_clients_.load(); }
  int64_t NumFramesPublished() const;
  int64_t NumFramesSent() const { return num_frames_sent_.load(); }
  // Waits until at least n clients are streaming (for tests); false on timeout.
  bool WaitForStreamClients(int n, std::chrono::milliseconds timeout) const;

 private:
  struct Client {
    std::thread thread;
    Socket socket;
    std::atomic<bool> done{false};
  };
  void AcceptLoop();
  void SourceLoop();
  void ServeClient(Client* client);
  void Stream(int fd);

  MjpegServerOptions options_;
  FrameSource source_;
  RouteHandler routes_;
  Socket listener_;
  int port_ = 0;
  std::atomic<bool> stop_{false};
  bool started_ = false;
  std::thread accept_thread_, source_thread_;

  mutable std::mutex clients_mutex_;
  std::vector<std::unique_ptr<Client>> clients_;

  mutable std::mutex frame_mutex_;
  mutable std::condition_variable frame_cv_;
  std::shared_ptr<const std::vector<uint8_t>> frame_;
  int64_t frame_seq_ = 0;
  int64_t frame_stamp_us_ = 0;
  std::atomic<int> num_stream_clients_{0};
  std::atomic<int64_t> num_frames_sent_{0};
};

}  // namespace owlcal::robot
