#include "sim/sim_server.h"

#include <chrono>
#include <stdexcept>

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
  servo_server_ = std::make_unique<robot::ServoServer>(so, [this](const models::PwmVector& pwm) { owl_->SendServos(pwm); });
  robot::MjpegServerOptions ho;
  ho.bind_address = options_.bind_address;
  ho.port = options_.http_port;
  ho.fps = owl_->Truth().stream.fps;
  ho.log = options_.log;
  http_server_ = std::make_unique<robot::MjpegServer>(ho, nullptr, [this](const robot::HttpRequest& r) { return Route(r); });
  servo_server_->Start();
  http_server_->Start();
  stop_ = false;
  stream_thread_ = std::thread([this] { StreamLoop(); });
}

void SimServer::Stop() {
  stop_ = true;
  if (stream_thread_.joinable()) stream_thread_.join();
  if (http_server_) http_server_->Stop();
  if (servo_server_) servo_server_->Stop();
}

int SimServer::ServoPort() const { return servo_server_ ? servo_server_->Port() : 0; }
int SimServer::HttpPort() const { return http_server_ ? http_server_->Port() : 0; }
robot::ServoServerStats SimServer::ServoStats() const { return servo_server_ ? servo_server_->Stats() : robot::ServoServerStats{}; }
int64_t SimServer::NumFramesPublished() const { return http_server_ ? http_server_->NumFramesPublished() : 0; }

void SimServer::StreamLoop() {
  int64_t after = -1;
  while (!stop_) {
    // Short timeouts so Stop() is prompt; frames come at the truth's fps.
    auto frame = owl_->GrabFrame(after, 100'000'000);
    if (!frame) continue;
    after = frame->stamp_ns;
    // X-Timestamp = the left eye's exposure on the steady clock (mjpg-streamer sends the capture
    // time), so a client can tell a frame's age: now - X-Timestamp = latency + time in transit.
    const int64_t exposure_ns = owl_->ExposureNs(frame->seq, models::kLeftEye);
    const int64_t steady_us =
        std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now().time_since_epoch())
            .count();
    const int64_t age_us = (owl_->NowNs() - exposure_ns) / 1000;
    // Beyond the configured latency: rendering and encoding (a loaded machine falls behind).
    const int64_t lag_us = age_us - static_cast<int64_t>(owl_->Truth().stream.latency_ms * 1000);
    if (lag_us > max_publish_lag_us_.load()) max_publish_lag_us_ = lag_us;
    http_server_->Publish(std::move(frame->jpeg), steady_us - age_us);
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
