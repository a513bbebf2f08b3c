#pragma once
// The robot options shared by the commands that drive a robot through protocols (run,
// calibrate): which robot, its robot file, and for the virtual Owl its truth, scene and seed.
#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "apps/robot_factory.h"
#include "pipeline/calibrate.h"
#include "protocols/runner.h"

namespace owlcal::apps {

struct RobotOptions {
  std::string robot = "sim";  // "sim" (in-process virtual Owl) or HOST[:PORT]
  std::string robot_file;
  std::string robot_truth;
  std::string scene;
  uint64_t seed = 1;
  int http_port = 8080;

  bool IsSim() const { return robot == "sim"; }

  RobotFactoryOptions Factory() const {
    RobotFactoryOptions fo;
    fo.robot_file = robot_file;
    fo.truth_file = robot_truth;
    fo.scene_file = scene;
    fo.seed = seed;
    fo.http_port = http_port;
    return fo;
  }

  // What a dataset's manifest records about the robot.
  pipeline::RobotRecord Record() const {
    pipeline::RobotRecord r;
    r.spec = robot;
    r.robot_file = robot_file;
    if (!robot_file.empty()) {
      std::ifstream in(robot_file);
      std::ostringstream s;
      s << in.rdbuf();
      r.robot_file_text = s.str();
    }
    if (IsSim()) r.sim = {{"seed", seed}, {"truth_file", robot_truth}, {"scene_file", scene}};
    return r;
  }

  // The same, as a protocol run's options record it.
  void FillRunOptions(protocols::RunOptions* ro) const {
    const pipeline::RobotRecord r = Record();
    ro->robot_spec = r.spec;
    ro->robot_file = r.robot_file;
    ro->robot_file_text = r.robot_file_text;
    ro->sim = r.sim;
  }
};

inline void AddRobotOptions(CLI::App* cmd, RobotOptions* o) {
  cmd->add_option("--robot", o->robot, "'sim' (in-process virtual Owl, default) or the robot's HOST[:PORT]");
  cmd->add_option("--robot-file", o->robot_file, "robot file (limits, centres); default: the guide's robot")
      ->check(CLI::ExistingFile);
  cmd->add_option("--robot-truth", o->robot_truth, "sim: robot-truth file; default: the built-in robot")
      ->check(CLI::ExistingFile);
  cmd->add_option("--scene", o->scene, "sim: scene file; default: the built-in scene")->check(CLI::ExistingFile);
  cmd->add_option("--seed", o->seed, "sim: random seed");
  cmd->add_option("--http-port", o->http_port, "real robot: MJPEG stream port")->check(CLI::Range(1, 65535));
}

}  // namespace owlcal::apps
