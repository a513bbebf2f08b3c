#include "apps/robot_factory.h"

#include <iostream>
#include <stdexcept>

#include "robot/owl_link.h"
#include "robot/robot_file.h"
#include "robot/socket_util.h"
#include "sim/virtual_owl.h"

namespace owlcal::apps {

std::unique_ptr<robot::RobotInterface> MakeRobot(const std::string& spec, const RobotFactoryOptions& options) {
  if (spec.empty()) throw std::invalid_argument("--robot is empty: give 'sim' or the robot's HOST[:PORT]");
  if (spec == "sim") {
    sim::VirtualOwlOptions vo;
    vo.truth_file = options.truth_file;
    vo.scene_file = options.scene_file;
    vo.seed = options.seed;
    if (!options.robot_file.empty() || options.robot_config) {
      // The robot file the "server" is configured with (clamp limits) over the truth.
      sim::RobotTruth truth =
          options.truth_file.empty() ? sim::DefaultRobotTruth() : sim::LoadRobotTruth(options.truth_file);
      truth.robot = options.robot_config ? *options.robot_config : robot::LoadRobotFile(options.robot_file);
      vo.truth = truth;
    }
    return std::make_unique<sim::VirtualOwl>(vo);
  }
  const robot::HostPort hp = robot::ParseHostPort(spec, robot::kDefaultServoPort);
  robot::OwlLinkOptions lo;
  lo.host = hp.host;
  lo.servo_port = hp.port;
  lo.http_port = options.http_port;
  lo.robot = options.robot_config         ? *options.robot_config
             : options.robot_file.empty() ? models::DefaultRobotConfig()
                                          : robot::LoadRobotFile(options.robot_file);
  lo.log = options.log ? options.log : [](const std::string& line) { std::cerr << "owlcal: " << line << "\n"; };
  return std::make_unique<robot::OwlLink>(lo);
}

}  // namespace owlcal::apps
