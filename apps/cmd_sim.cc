// owlcal sim: runs the virtual Owl in real time behind the robot's own protocols (servo TCP
// packets and the MJPEG stream), or exports its ground truth.
//
// Consumes: a robot-truth file (--robot-truth, default built in = data/sim/owl_default_truth.yaml)
// and a scene file (--scene, default built in). Produces: the served robot on --bind
// (127.0.0.1 unless told otherwise), or with --write-truth FILE the full truth (YAML, or
// JSON with scene and servo state if FILE ends in .json) and exit.
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <thread>

#include "apps/command_registry.h"
#include "reports/table.h"
#include "robot/socket_util.h"
#include "sim/sim_server.h"

namespace owlcal::apps {
namespace {

std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }

struct SimCommandOptions {
  std::string truth_file;
  std::string scene_file;
  std::string bind = "127.0.0.1";
  int servo_port = 12345;
  int http_port = 8080;
  uint64_t seed = 1;
  std::string write_truth;
  double duration_s = 0;
  double latency_ms = -1;
  double noise_sigma = -1;
  double drop_probability = -1;
  int jpeg_quality = 0;
  int quantum_us = 0;
  std::string server = "owlcal";
  double idle_timeout_s = 5;
  int mirror = -1;  // -1: as the truth file says (default: mirrored, as a real Owl); 0/1: --no-mirror/--mirror
  int swap = -1;    // -1: as the truth file says (default: not swapped); 0/1: --no-swap/--swap
  bool quiet = false;
};

// How a client must read the stream of a robot with this layout (printed at start).
std::string LayoutText(const models::RobotConfig& r) {
  std::string s = r.mirror_stream ? "mirrored like a real Owl's (flip the whole frame, then " : "not mirrored (";
  s += r.swap_eyes ? "left eye = columns 640-1279)" : "left eye = columns 0-639)";
  return s;
}

std::string ServerText(robot::ServoServerOptions::Mode mode, std::chrono::milliseconds idle_timeout) {
  switch (mode) {
    case robot::ServoServerOptions::Mode::kPython:
      return "python (the guide's Annex 2 server: one client; a short packet or a bad field ends it)";
    case robot::ServoServerOptions::Mode::kC:
      return "c (MRSsocket.c: per-field parse and clamp, replies with the Rx value; exits when its one client "
             "leaves)";
    case robot::ServoServerOptions::Mode::kOwlcal:
      break;
  }
  char seconds[32];
  std::snprintf(seconds, sizeof seconds, "%g", double(idle_timeout.count()) / 1000.0);
  return std::string("owlcal (clients one after another; a session silent for ") + seconds +
         " s is closed when another client waits)";
}

int RunSim(const SimCommandOptions& o) {
  sim::SimServerOptions so;
  so.owl.truth_file = o.truth_file;
  so.owl.scene_file = o.scene_file;
  so.owl.seed = o.seed;
  if (o.latency_ms >= 0) so.owl.latency_ms = o.latency_ms;
  if (o.noise_sigma >= 0) so.owl.noise_sigma = o.noise_sigma;
  if (o.drop_probability >= 0) so.owl.drop_probability = o.drop_probability;
  if (o.jpeg_quality > 0) so.owl.jpeg_quality = o.jpeg_quality;
  if (o.quantum_us > 0) so.owl.quantum_us = o.quantum_us;
  if (o.mirror >= 0 || o.swap >= 0) {
    sim::RobotTruth truth = o.truth_file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(o.truth_file);
    if (o.mirror >= 0) truth.robot.mirror_stream = o.mirror == 1;
    if (o.swap >= 0) truth.robot.swap_eyes = o.swap == 1;
    so.owl.truth = truth;
  }
  so.bind_address = o.bind;
  try {
    so.servo_mode = robot::ParseServerMode(o.server);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--server: ") + e.what());
  }
  if (!(o.idle_timeout_s > 0 && o.idle_timeout_s <= 86400)) {
    throw UsageError("--idle-timeout " + std::to_string(o.idle_timeout_s) + " is not in (0, 86400] s");
  }
  so.idle_timeout = std::chrono::milliseconds(static_cast<int64_t>(o.idle_timeout_s * 1000));
  so.servo_port = o.servo_port;
  so.http_port = o.http_port;
  if (!o.quiet) so.log = [](const std::string& m) { std::cerr << "owlcal sim: " << m << "\n"; };
  std::string why;
  if (!so.Check(&why)) throw UsageError(why);

  if (!o.write_truth.empty()) {
    sim::VirtualOwl owl(so.owl);
    const bool json = o.write_truth.size() >= 5 && o.write_truth.substr(o.write_truth.size() - 5) == ".json";
    if (json) {
      reports::WriteTextFile(o.write_truth, owl.TruthJson() + "\n");
    } else {
      sim::SaveRobotTruth(owl.Truth(), o.write_truth);
    }
    std::cout << "wrote the truth of " << owl.Describe() << " to " << o.write_truth << "\n";
    return kExitOk;
  }

  if (!robot::IsLoopbackAddress(o.bind)) {
    std::cerr << "owlcal sim: warning: binding " << o.bind << " exposes the virtual Owl beyond this machine\n";
  }
  sim::SimServer server(so);
  server.Start();
  // An IPv6 literal goes in brackets in a URL.
  const std::string host = o.bind.find(':') != std::string::npos && o.bind.front() != '[' ? "[" + o.bind + "]" : o.bind;
  std::cout << server.Owl().Describe() << "\n"
            << "  stream layout: " << LayoutText(server.Owl().Config()) << "\n"
            << "  servo server:  " << ServerText(so.servo_mode, so.idle_timeout) << "\n"
            << "  servo packets: " << host << ":" << server.ServoPort() << "\n"
            << "  stream:        http://" << host << ":" << server.HttpPort() << "/stream/video.mjpeg\n"
            << "  truth:         http://" << host << ":" << server.HttpPort() << "/truth\n"
            << "  move a target: PUT http://" << host << ":" << server.HttpPort()
            << "/scene/targets/NAME  {\"t_m\": [x, y, z], \"rpy_deg\": [r, p, y]}\n"
            << (o.duration_s > 0 ? "" : "Ctrl-C stops.\n") << std::flush;
  g_stop = false;
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  const auto start = std::chrono::steady_clock::now();
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (o.duration_s > 0 && std::chrono::steady_clock::now() - start > std::chrono::duration<double>(o.duration_s))
      break;
  }
  const auto stats = server.ServoStats();
  server.Stop();
  std::cout << "served " << server.NumFramesPublished() << " frames, " << stats.num_packets << " servo packets ("
            << stats.num_malformed << " malformed, " << stats.num_clamped << " clamped) in " << stats.num_sessions
            << " sessions\n";
  if (server.ServoServerExited()) {
    std::cout << "the " << o.server << " servo server had exited: " << server.ServoServerExitReason() << "\n";
  }
  return kExitOk;
}

const bool kSimRegistered = RegisterCommand(
    "sim",
    "Run the virtual Owl in real time (servo TCP + MJPEG stream on loopback), or --write-truth FILE",
    [](CLI::App* cmd) {
      auto o = std::make_shared<SimCommandOptions>();
      cmd->add_option(
             "--robot-truth", o->truth_file, "robot-truth YAML (default: built-in = data/sim/owl_default_truth.yaml)")
          ->check(CLI::ExistingFile);
      cmd->add_option("--scene", o->scene_file, "scene YAML (default: built-in)")->check(CLI::ExistingFile);
      cmd->add_option("--bind", o->bind, "address to listen on (IPv4, or an IPv6 literal such as ::1)")
          ->capture_default_str();
      cmd->add_option("--server",
                      o->server,
                      "servo server: owlcal (robust, default), python (the guide's Annex 2 server) or c (the course's "
                      "MRSsocket.c: one client per launch)")
          ->capture_default_str();
      cmd->add_option("--idle-timeout",
                      o->idle_timeout_s,
                      "owlcal server: close a session silent this many seconds when another client is waiting")
          ->capture_default_str();
      cmd->add_option("--servo-port", o->servo_port, "servo TCP port (0 = any free)")->capture_default_str();
      cmd->add_option("--http-port", o->http_port, "MJPEG/HTTP port (0 = any free)")->capture_default_str();
      cmd->add_option("--seed", o->seed, "noise/drop seed")->capture_default_str();
      cmd->add_option(
          "--write-truth", o->write_truth, "write the ground truth to FILE (.yaml, or .json with scene) and exit");
      cmd->add_option("--duration", o->duration_s, "stop after this many seconds (0 = until Ctrl-C)");
      cmd->add_option("--latency-ms", o->latency_ms, "override the stream latency");
      cmd->add_option("--noise-sigma", o->noise_sigma, "override the sensor noise [grey levels]");
      cmd->add_option("--drop-probability", o->drop_probability, "override the frame drop probability");
      cmd->add_option("--jpeg-quality", o->jpeg_quality, "override the JPEG quality (1-100)");
      cmd->add_option("--quantum-us", o->quantum_us, "override the PWM quantum of all servos (1, or 5 as pigpio)");
      cmd->add_flag_callback(
          "--mirror",
          [o] { o->mirror = 1; },
          "stream mirrored like a real Owl's (the default): the course code flips the frame");
      cmd->add_flag_callback(
          "--no-mirror", [o] { o->mirror = 0; }, "stream not mirrored (eyes the right way round)");
      cmd->add_flag_callback(
          "--swap", [o] { o->swap = 1; }, "left eye in columns 640-1279 (after any flip)");
      cmd->add_flag_callback(
          "--no-swap", [o] { o->swap = 0; }, "left eye in columns 0-639 (after any flip; the default)");
      cmd->add_flag("--quiet", o->quiet, "no per-session log lines");
      return [o] { return RunSim(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
