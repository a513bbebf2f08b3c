#pragma once
// OwlLink: a real (or served virtual) Owl over the network, as a RobotInterface.
// Servo commands go through a LimitsGuard (the robot file's limits) and a ServoClient
// (host:servo_port, default 12345); frames come from an MjpegClient (host:http_port, default
// 8080, /stream/video.mjpeg) read on a background thread that keeps only the newest frame,
// so GrabFrame never returns a stale buffered one. Left/right follow the robot file's
// swap_eyes / mirror options (robot/mjpeg_client.h).
// Clock: the host's steady clock (NowNs, SleepNs). No scene control (Scene() is nullptr).
// One servo connection for the whole life of the link (the course's C server serves one client
// per launch); if it is lost the ServoClient reconnects once, and the link logs that it did.
//
// Usage:
//   OwlLinkOptions o;
//   o.host = "10.0.0.10";                       // always explicit
//   o.robot = LoadRobotFile("data/robots/guide-owl.yaml");
//   OwlLink owl(o);
//   owl.SendServos(owl.Config().Centre());
//   auto frame = owl.GrabFrame(owl.NowNs(), 2'000'000'000);
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>

#include "robot/limits_guard.h"
#include "robot/mjpeg_client.h"
#include "robot/robot_interface.h"
#include "robot/servo_client.h"

namespace owlcal::robot {

inline constexpr int kDefaultServoPort = 12345;
inline constexpr int kDefaultHttpPort = 8080;

struct OwlLinkOptions {
  std::string host;  // no default: never assume a robot
  int servo_port = kDefaultServoPort;
  int http_port = kDefaultHttpPort;
  std::string stream_path = "/stream/video.mjpeg";
  models::RobotConfig robot = models::DefaultRobotConfig();
  std::chrono::milliseconds connect_timeout{2000};
  std::chrono::milliseconds reply_timeout{1000};
  std::chrono::milliseconds command_timeout{0};  // > 0: one command, retries included, takes at most this
  LogSink log;                                   // clamps and link events
  bool Check(std::string* why) const;
};

class OwlLink : public RobotInterface {
 public:
  explicit OwlLink(OwlLinkOptions options);  // throws std::invalid_argument if !Check
  ~OwlLink() override;

  const models::RobotConfig& Config() const override { return options_.robot; }
  // Clamps, sends, waits for the reply. Throws std::runtime_error if no reply came after
  // every attempt (the message names host:port).
  ServoReply SendServos(const PwmVector& pwm_us) override;
  // Starts the stream on first use. Waits up to timeout_ns for a frame stamped after
  // after_stamp_ns; nullopt on timeout.
  std::optional<StereoFrame> GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) override;
  int64_t NowNs() override;
  void SleepNs(int64_t ns) override;
  std::string Describe() const override;

  // Ends the servo session (the course server's empty packet) and stops the stream.
  void Close();
  MjpegClientStats StreamStats() const;
  const LimitsGuard& Guard() const { return guard_; }

 private:
  void StreamLoop();

  OwlLinkOptions options_;
  LimitsGuard guard_;
  ServoClient servo_;
  MjpegClientOptions stream_options_;

  mutable std::mutex mutex_;
  std::condition_variable frame_cv_;
  std::optional<StereoFrame> latest_;
  MjpegClientStats stream_stats_;
  bool stream_started_ = false;
  bool stop_ = false;
  std::thread stream_thread_;
};

}  // namespace owlcal::robot
