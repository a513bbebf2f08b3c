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
  bool quiet = false;
};

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
  so.bind_address = o.bind;
  so.servo_port = o.servo_port;
  so.http_port = o.http_port;
  if (!o.quiet) so.log = [](const std::string& m) { std::cerr << "owlcal sim: " << m << "\n"; };
  std::string why;
  if (!so.Check(&why)) throw UsageError(why);

  if (!o.write_truth.empty()) {
    sim::VirtualOwl owl(so.owl);
    const bool json = o.write_truth.size() >= 5 && o.write_truth.substr(o.write_truth.size() - 5) == ".json";
    if (json) {
      std::ofstream out(o.write_truth);
      out << owl.TruthJson() << "\n";
      if (!out) throw std::runtime_error(o.write_truth + ": cannot write the truth");
    } else {
      sim::SaveRobotTruth(owl.Truth(), o.write_truth);
    }
    std::cout << "wrote the truth of " << owl.Describe() << " to " << o.write_truth << "\n";
    return kExitOk;
  }

  if (o.bind != "127.0.0.1" && o.bind != "localhost") {
    std::cerr << "owlcal sim: warning: binding " << o.bind << " exposes the virtual Owl beyond this machine\n";
  }
  sim::SimServer server(so);
  server.Start();
  std::cout << server.Owl().Describe() << "\n"
            << "  servo packets: " << o.bind << ":" << server.ServoPort() << "\n"
            << "  stream:        http://" << o.bind << ":" << server.HttpPort() << "/stream/video.mjpeg\n"
            << "  truth:         http://" << o.bind << ":" << server.HttpPort() << "/truth\n"
            << "  move a target: PUT http://" << o.bind << ":" << server.HttpPort()
            << "/scene/targets/NAME  {\"t_m\": [x, y, z], \"rpy_deg\": [r, p, y]}\n"
            << (o.duration_s > 0 ? "" : "Ctrl-C stops.\n") << std::flush;
  g_stop = false;
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  const auto start = std::chrono::steady_clock::now();
  while (!g_stop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    if (o.duration_s > 0 && std::chrono::steady_clock::now() - start > std::chrono::duration<double>(o.duration_s)) break;
  }
  const auto stats = server.ServoStats();
  server.Stop();
  std::cout << "served " << server.NumFramesPublished() << " frames, " << stats.num_packets << " servo packets ("
            << stats.num_malformed << " malformed, " << stats.num_clamped << " clamped) in " << stats.num_sessions
            << " sessions\n";
  return kExitOk;
}

const bool kRegistered = RegisterCommand(
    "sim",
    "Run the virtual Owl in real time (servo TCP + MJPEG stream on loopback), or --write-truth FILE",
    [](CLI::App* cmd) {
      auto o = std::make_shared<SimCommandOptions>();
      cmd->add_option("--robot-truth", o->truth_file, "robot-truth YAML (default: built-in = data/sim/owl_default_truth.yaml)")
          ->check(CLI::ExistingFile);
      cmd->add_option("--scene", o->scene_file, "scene YAML (default: built-in)")->check(CLI::ExistingFile);
      cmd->add_option("--bind", o->bind, "address to listen on")->capture_default_str();
      cmd->add_option("--servo-port", o->servo_port, "servo TCP port (0 = any free)")->capture_default_str();
      cmd->add_option("--http-port", o->http_port, "MJPEG/HTTP port (0 = any free)")->capture_default_str();
      cmd->add_option("--seed", o->seed, "noise/drop seed")->capture_default_str();
      cmd->add_option("--write-truth", o->write_truth, "write the ground truth to FILE (.yaml, or .json with scene) and exit");
      cmd->add_option("--duration", o->duration_s, "stop after this many seconds (0 = until Ctrl-C)");
      cmd->add_option("--latency-ms", o->latency_ms, "override the stream latency");
      cmd->add_option("--noise-sigma", o->noise_sigma, "override the sensor noise [grey levels]");
      cmd->add_option("--drop-probability", o->drop_probability, "override the frame drop probability");
      cmd->add_option("--jpeg-quality", o->jpeg_quality, "override the JPEG quality (1-100)");
      cmd->add_option("--quantum-us", o->quantum_us, "override the PWM quantum of all servos (1, or 5 as pigpio)");
      cmd->add_flag("--quiet", o->quiet, "no per-session log lines");
      return [o] { return RunSim(*o); };
    });

}  // namespace
}  // namespace owlcal::apps
