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
//   X-Timestamp: <sec>.<usec>\r\n  (server's steady clock when the frame was published)
//   \r\n<jpeg bytes>\r\n
// Frames come either from a FrameSource polled at options.fps on a server thread (nullopt =
// no frame this tick), or from Publish(jpeg) (push API). Every client gets the newest frame
// each time a new one is published (a slow client skips frames, as with the real server).
// One thread per client; any number of clients.
//
// Other routes: any request that is not a GET of the stream path goes to the RouteHandler
// (e.g. GET /truth, PUT /scene/targets/NAME with a JSON body); nullopt from it, or no
// handler, gives 404. Those responses close the connection (HTTP/1.0 style).
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
  int port = 0;                                // 0 = ephemeral; Port() tells
  std::string stream_path = "/stream/video.mjpeg";
  std::string boundary = "boundarydonotcross";  // as mjpg-streamer
  double fps = 30.0;                           // FrameSource polling rate [Hz]
  bool send_content_length = true;
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

  // Push API: makes `jpeg` the newest frame; clients receive it once.
  void Publish(std::vector<uint8_t> jpeg);
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
