#pragma once
// The served virtual Owl: a real-time VirtualOwl behind the robot's own network protocols,
// on loopback by default (owlcal sim):
//   - TCP servo server (robot/servo_server.h) in options.servo_mode: owlcal (default: 24-byte
//     packets joined across reads, "ok" before parsing, a malformed packet moves nothing, the
//     course server's clamp, idle sessions closed when another client waits), python (the
//     guide's Annex 2 server: one client, a bad field kills it) or c (MRSsocket.c: per-field
//     parse and clamp, replies with the Rx value, one client per launch) -> VirtualOwl::SendServos;
//   - HTTP (robot/mjpeg_server.h): GET /stream/video.mjpeg, the 1280x480 side-by-side MJPEG
//     at the truth's fps, laid out as the truth's robot section says (default: mirrored like a
//     real Owl's); like mjpg-streamer each client gets the newest frame and a slow client skips
//     frames (the queue is the socket buffers only); X-Timestamp is the frame's exposure time on
//     the steady clock; GET /truth (TruthJson); GET /scene/targets (names and poses);
//     PUT /scene/targets/NAME with a JSON pose body {"t_m": [x, y, z], "q_xyzw": [..4]} or
//     {"t_m": [...], "rpy_deg": [...]}, optionally "visible": true|false; 400 naming the
//     problem on a bad body, 404 on an unknown target.
// In owlcal mode malformed packets never move a servo; in c mode the fields that parse do
// (clamped), as on the course's C server.
//
// Usage:
//   SimServer server(options);   // options.owl.real_time is forced on
//   server.Start();
//   std::printf("servo port %d, http port %d\n", server.ServoPort(), server.HttpPort());
//   ... server.Stop();
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <utility>

#include "robot/mjpeg_server.h"
#include "robot/servo_server.h"
#include "sim/virtual_owl.h"

namespace owlcal::sim {

struct SimServerOptions {
  VirtualOwlOptions owl;
  std::string bind_address = "127.0.0.1";
  int servo_port = 12345;  // 0 = ephemeral
  int http_port = 8080;    // 0 = ephemeral
  robot::ServoServerOptions::Mode servo_mode = robot::ServoServerOptions::Mode::kOwlcal;
  std::chrono::milliseconds idle_timeout{5000};  // owlcal mode; see robot/servo_server.h
  robot::LogSink log;                            // session / clamp / malformed-packet messages
  bool Check(std::string* why) const;
};

class SimServer {
 public:
  explicit SimServer(SimServerOptions options);
  ~SimServer();
  SimServer(const SimServer&) = delete;
  SimServer& operator=(const SimServer&) = delete;

  // Binds both servers and starts streaming. Throws naming the address and port.
  void Start();
  void Stop();
  int ServoPort() const;
  int HttpPort() const;
  VirtualOwl& Owl() { return *owl_; }
  robot::ServoServerStats ServoStats() const;
  // The python or c servo server stopped by itself (as the course's does); why.
  bool ServoServerExited() const { return servo_server_ && servo_server_->Exited(); }
  std::string ServoServerExitReason() const { return servo_server_ ? servo_server_->ExitReason() : ""; }
  int64_t NumFramesPublished() const;
  // The largest delay of a frame's publication beyond the configured latency: rendering and JPEG
  // encoding start when the frame's exposure is over and lag only if they outlast the rest of the
  // latency (a loaded machine) [ms].
  double MaxPublishLagMs() const { return double(max_publish_lag_us_.load()) / 1000.0; }

 private:
  std::optional<robot::HttpResponse> Route(const robot::HttpRequest& request);
  void StreamLoop();   // renders each frame once its exposure is over
  void PublishLoop();  // publishes the rendered frames at their stamps
  // Sleeps until the owl's clock reaches t_ns; false if Stop() came first.
  bool SleepUntil(int64_t t_ns);

  SimServerOptions options_;
  std::unique_ptr<VirtualOwl> owl_;
  std::unique_ptr<robot::ServoServer> servo_server_;
  std::unique_ptr<robot::MjpegServer> http_server_;
  std::thread stream_thread_, publish_thread_;
  std::mutex rendered_mutex_;
  std::condition_variable rendered_cv_;
  std::deque<std::pair<int64_t, robot::StereoFrame>> rendered_;  // (seq, frame) awaiting their stamps
  std::atomic<bool> stop_{false};
  std::atomic<int64_t> max_publish_lag_us_{0};
};

}  // namespace owlcal::sim
