#include "robot/owl_link.h"

#include <stdexcept>

namespace owlcal::robot {

bool OwlLinkOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "owl link: " + m;
    return false;
  };
  if (host.empty()) return fail("no robot host given (pass --robot HOST[:PORT]; 10.0.0.10 is never assumed)");
  if (servo_port < 1 || servo_port > 65535)
    return fail("servo port " + std::to_string(servo_port) + " is not 1..65535");
  if (http_port < 1 || http_port > 65535) return fail("http port " + std::to_string(http_port) + " is not 1..65535");
  return true;
}

namespace {
ServoClientOptions ServoOptionsOf(const OwlLinkOptions& o) {
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument(why);
  ServoClientOptions s;
  s.host = o.host;
  s.port = o.servo_port;
  s.connect_timeout = o.connect_timeout;
  s.reply_timeout = o.reply_timeout;
  s.command_timeout = o.command_timeout;
  return s;
}
}  // namespace

OwlLink::OwlLink(OwlLinkOptions options)
    : options_(std::move(options)), guard_(options_.robot, options_.log), servo_(ServoOptionsOf(options_)) {
  stream_options_.host = options_.host;
  stream_options_.port = options_.http_port;
  stream_options_.path = options_.stream_path;
  stream_options_.connect_timeout = options_.connect_timeout;
  stream_options_.swap_eyes = options_.robot.swap_eyes;
  stream_options_.mirror_stream = options_.robot.mirror_stream;
  // Frames are checked against the robot file's size before they are decoded.
  stream_options_.expected_width = 2 * options_.robot.image_width;
  stream_options_.expected_height = options_.robot.image_height;
}

OwlLink::~OwlLink() { Close(); }

void OwlLink::Close() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  frame_cv_.notify_all();
  if (stream_thread_.joinable()) stream_thread_.join();
  servo_.Close();
}

ServoReply OwlLink::SendServos(const PwmVector& pwm_us) {
  const ClampResult clamp = guard_.Clamp(pwm_us);
  const int64_t connects_before = servo_.NumConnects();
  const ServoClientReply r = servo_.Send(clamp.pwm_us);
  if (connects_before > 0 && servo_.NumConnects() > connects_before && options_.log) {
    // One connection per run is the rule (a one-client server, such as the course's C server,
    // refuses a second one); a reconnect is never silent.
    options_.log("servo link: the connection to " + options_.host + ":" + std::to_string(options_.servo_port) +
                 " was lost and has been re-opened (" + std::to_string(servo_.NumConnects()) +
                 " connections in this run); a one-client server such as the course's C server refuses this");
  }
  if (!r.ok) {
    std::string sent;
    for (int i = 0; i < models::kNumServos; ++i) {
      if (i) sent += ' ';
      sent += std::to_string(clamp.pwm_us[i]);
    }
    throw std::runtime_error("servo command [" + sent + "] " + (r.bad_reply ? "failed: " : "not answered: ") + r.error);
  }
  ServoReply reply;
  reply.ok = r.ok;
  reply.text = r.text;
  reply.sent = clamp.pwm_us;
  reply.clamped = clamp.any_clamped;
  return reply;
}

void OwlLink::StreamLoop() {
  MjpegClient client(stream_options_);
  while (true) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (stop_) break;
    }
    std::optional<MjpegFrame> f = client.Next(std::chrono::milliseconds(200));
    std::lock_guard<std::mutex> lock(mutex_);
    stream_stats_ = client.Stats();
    if (f) {
      latest_ = std::move(f->stereo);
      frame_cv_.notify_all();
    }
  }
}

std::optional<StereoFrame> OwlLink::GrabFrame(int64_t after_stamp_ns, int64_t timeout_ns) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!stream_started_) {
    stream_started_ = true;
    stop_ = false;
    stream_thread_ = std::thread([this] { StreamLoop(); });
  }
  const bool got = frame_cv_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), [&] {
    return stop_ || (latest_ && latest_->stamp_ns > after_stamp_ns);
  });
  if (!got || !latest_ || latest_->stamp_ns <= after_stamp_ns) return std::nullopt;
  StereoFrame out = *latest_;
  return out;
}

int64_t OwlLink::NowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

void OwlLink::SleepNs(int64_t ns) {
  if (ns > 0) std::this_thread::sleep_for(std::chrono::nanoseconds(ns));
}

std::string OwlLink::Describe() const {
  return options_.host + ":" + std::to_string(options_.servo_port) + " (stream http://" + options_.host + ":" +
         std::to_string(options_.http_port) + options_.stream_path + ", robot " + options_.robot.name + ")";
}

MjpegClientStats OwlLink::StreamStats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return stream_stats_;
}

}  // namespace owlcal::robot
