#include "sim/sim_server.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <thread>

#include <nlohmann/json.hpp>

namespace owlcal::sim {

bool SimServerOptions::Check(std::string* why) const {
  if (!owl.Check(why)) return false;
  if (servo_port < 0 || servo_port > 65535) {
    if (why) *why = "servo_port = " + std::to_string(servo_port) + " is not a port";
    return false;
  }
  if (http_port < 0 || http_port > 65535) {
    if (why) *why = "http_port = " + std::to_string(http_port) + " is not a port";
    return false;
  }
  if (bind_address.empty()) {
    if (why) *why = "bind_address is empty";
    return false;
  }
  if (idle_timeout.count() <= 0) {
    if (why) *why = "idle_timeout must be positive";
    return false;
  }
  return true;
}

SimServer::SimServer(SimServerOptions options) : options_(std::move(options)) {
  std::string why;
  if (!options_.Check(&why)) throw std::invalid_argument("SimServerOptions: " + why);
  options_.owl.real_time = true;
  options_.owl.encode_jpeg = true;
  options_.owl.decode_frames = false;
  owl_ = std::make_unique<VirtualOwl>(options_.owl);
}

SimServer::~SimServer() { Stop(); }

void SimServer::Start() {
  robot::ServoServerOptions so;
  so.bind_address = options_.bind_address;
  so.port = options_.servo_port;
  so.robot = owl_->Config();
  so.log = options_.log;
  so.mode = options_.servo_mode;
  so.idle_timeout = options_.idle_timeout;
  servo_server_ =
      std::make_unique<robot::ServoServer>(so, [this](const models::PwmVector& pwm) { owl_->SendServos(pwm); });
  robot::MjpegServerOptions ho;
  ho.bind_address = options_.bind_address;
  ho.port = options_.http_port;
  ho.fps = owl_->Truth().stream.fps;
  ho.log = options_.log;
  http_server_ =
      std::make_unique<robot::MjpegServer>(ho, nullptr, [this](const robot::HttpRequest& r) { return Route(r); });
  servo_server_->Start();
  http_server_->Start();
  stop_ = false;
  stream_thread_ = std::thread([this] { StreamLoop(); });
  publish_thread_ = std::thread([this] { PublishLoop(); });
}

void SimServer::Stop() {
  stop_ = true;
  if (stream_thread_.joinable()) stream_thread_.join();
  if (publish_thread_.joinable()) publish_thread_.join();
  rendered_.clear();
  if (http_server_) http_server_->Stop();
  if (servo_server_) servo_server_->Stop();
}

int SimServer::ServoPort() const { return servo_server_ ? servo_server_->Port() : 0; }
int SimServer::HttpPort() const { return http_server_ ? http_server_->Port() : 0; }
robot::ServoServerStats SimServer::ServoStats() const {
  return servo_server_ ? servo_server_->Stats() : robot::ServoServerStats{};
}
int64_t SimServer::NumFramesPublished() const { return http_server_ ? http_server_->NumFramesPublished() : 0; }

bool SimServer::SleepUntil(int64_t t_ns) {
  // Short steps so Stop() is prompt.
  for (int64_t now = owl_->NowNs(); !stop_ && now < t_ns; now = owl_->NowNs()) {
    std::this_thread::sleep_for(std::chrono::nanoseconds(std::min<int64_t>(t_ns - now, 20'000'000)));
  }
  return !stop_;
}

void SimServer::StreamLoop() {
  // A frame is rendered as soon as its exposure is over (both eyes, every row: the servo angles
  // and target poses it shows are known by then) and published at its stamp (exposure +
  // latency) by PublishLoop, so the rendering hides inside the stream's latency instead of adding
  // to it. The frames whose exposure ended while one was rendering are skipped: the next is the
  // newest exposed (a loaded machine streams fewer frames, never older ones).
  const StreamTruth& stream = owl_->Truth().stream;
  const double period_ns = 1e9 / stream.fps;
  const int64_t exposing_ns =
      int64_t(std::llround((std::max(0.0, stream.eye_offset_ms) + std::max(0.0, stream.rolling_shutter_ms)) * 1e6));
  auto exposed_ns = [&](int64_t seq) { return owl_->ExposureNs(seq, models::kLeftEye) + exposing_ns; };
  auto newest_exposed = [&](int64_t t_ns) {
    int64_t k = int64_t(std::floor(double(t_ns - exposing_ns) / period_ns));
    while (exposed_ns(k + 1) <= t_ns) ++k;
    while (k >= 0 && exposed_ns(k) > t_ns) --k;
    return k;
  };
  int64_t seq = std::max<int64_t>(0, newest_exposed(owl_->NowNs()) + 1);
  while (!stop_) {
    while (owl_->IsDropped(seq)) ++seq;
    if (!SleepUntil(exposed_ns(seq))) break;
    robot::StereoFrame frame = owl_->RenderFrame(seq);
    {
      std::lock_guard<std::mutex> lock(rendered_mutex_);
      rendered_.emplace_back(seq, std::move(frame));
    }
    rendered_cv_.notify_all();
    seq = std::max(seq + 1, newest_exposed(owl_->NowNs()));
  }
  rendered_cv_.notify_all();
}

void SimServer::PublishLoop() {
  while (!stop_) {
    int64_t seq;
    robot::StereoFrame frame;
    {
      std::unique_lock<std::mutex> lock(rendered_mutex_);
      if (!rendered_cv_.wait_for(lock, std::chrono::milliseconds(20), [&] { return stop_ || !rendered_.empty(); }) ||
          stop_) {
        continue;
      }
      seq = rendered_.front().first;
      frame = std::move(rendered_.front().second);
      rendered_.pop_front();
    }
    if (!SleepUntil(owl_->StampNs(seq))) break;
    // X-Timestamp = the left eye's exposure on the steady clock (mjpg-streamer sends the capture
    // time), so a client can tell a frame's age: now - X-Timestamp = latency + time in transit.
    const int64_t exposure_ns = owl_->ExposureNs(seq, models::kLeftEye);
    const int64_t steady_us =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count();
    const int64_t age_us = (owl_->NowNs() - exposure_ns) / 1000;
    // Beyond the configured latency: rendering that did not finish by the stamp (a loaded machine).
    const int64_t lag_us = age_us - static_cast<int64_t>(owl_->Truth().stream.latency_ms * 1000);
    if (lag_us > max_publish_lag_us_.load()) max_publish_lag_us_ = lag_us;
    http_server_->Publish(std::move(frame.jpeg), steady_us - age_us);
  }
}

std::optional<robot::HttpResponse> SimServer::Route(const robot::HttpRequest& request) {
  auto json_response = [](int status, const nlohmann::json& body) {
    robot::HttpResponse r;
    r.status = status;
    r.content_type = "application/json";
    r.body = body.dump(2) + "\n";
    return r;
  };
  if (request.method == "GET" && request.path == "/truth") {
    robot::HttpResponse r;
    r.content_type = "application/json";
    r.body = owl_->TruthJson() + "\n";
    return r;
  }
  if (request.method == "GET" && request.path == "/scene/targets") {
    return json_response(200, SceneJson(owl_->SceneState())["targets"]);
  }
  const std::string prefix = "/scene/targets/";
  if (request.path.rfind(prefix, 0) == 0) {
    const std::string name = request.path.substr(prefix.size());
    if (!owl_->TargetPose(name)) return json_response(404, {{"error", "no scene target named '" + name + "'"}});
    if (request.method == "GET") {
      // The scene JSON is held by name: a range-for over a member of a temporary would read freed memory.
      const nlohmann::json scene = SceneJson(owl_->SceneState());
      for (const auto& t : scene.at("targets"))
        if (t.at("name") == name) return json_response(200, t);
    }
    if (request.method == "PUT" || request.method == "POST") {
      try {
        const nlohmann::json body = nlohmann::json::parse(request.body);
        if (body.contains("t_m")) owl_->SetTargetPose(name, PoseFromJson(body));
        if (body.contains("visible")) owl_->SetTargetVisible(name, body.at("visible").get<bool>());
        if (!body.contains("t_m") && !body.contains("visible")) {
          return json_response(400, {{"error", "body needs t_m (+ q_xyzw or rpy_deg) and/or visible"}});
        }
      } catch (const std::exception& e) {
        return json_response(400, {{"error", std::string("PUT ") + request.path + ": " + e.what()}});
      }
      return json_response(200, {{"ok", true}, {"name", name}, {"pose", PoseJson(*owl_->TargetPose(name))}});
    }
    return json_response(405, {{"error", request.method + " not allowed on " + request.path}});
  }
  return std::nullopt;
}

}  // namespace owlcal::sim
