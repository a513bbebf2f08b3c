#include "robot/link_commands.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "io/atomic_file.h"
#include "robot/mjpeg_client.h"
#include "robot/owl_link.h"
#include "robot/robot_file.h"
#include "robot/socket_util.h"

namespace owlcal::robot {
namespace {

std::string PwmText(const PwmVector& p) {
  std::ostringstream s;
  for (int i = 0; i < models::kNumServos; ++i) s << (i ? " " : "") << p[i];
  return s.str();
}

}  // namespace

models::RobotConfig RobotConfigOrDefault(const std::string& path) {
  return path.empty() ? models::DefaultRobotConfig() : LoadRobotFile(path);
}

std::string MoveReport::Text() const {
  std::ostringstream s;
  s << "robot:   " << robot << "\n";
  s << "sent:    " << PwmText(reply.sent) << "   (Rx Ry Lx Ly Neck, us)\n";
  if (reply.clamped) s << "clamped: requested " << PwmText(requested) << "; " << clamp_message << "\n";
  s << "reply:   \"" << reply.text << "\"" << (reply.text == "ok" ? "   (the server answers ok before parsing)" : "")
    << "\n";
  return s.str();
}

MoveReport SendOneCommand(const std::string& robot_hostport,
                          const models::RobotConfig& robot,
                          const PwmVector& pwm_us,
                          std::chrono::milliseconds timeout) {
  const HostPort hp = ParseHostPort(robot_hostport, kDefaultServoPort);
  MoveReport report;
  report.robot = hp.ToString();
  report.requested = pwm_us;
  OwlLinkOptions o;
  o.host = hp.host;
  o.servo_port = hp.port;
  o.robot = robot;
  o.connect_timeout = timeout;
  o.reply_timeout = timeout;
  o.command_timeout = timeout;  // --timeout-ms bounds the whole command, reconnect included
  o.log = [&report](const std::string& line) { report.clamp_message = line; };
  OwlLink link(o);
  report.reply = link.SendServos(pwm_us);
  link.Close();
  return report;
}

std::string GrabReport::Text() const {
  std::ostringstream s;
  s << "frame " << width << "x" << height << "\n";
  s << "wrote " << left_png << "\nwrote " << right_png << "\nwrote " << frame_jpg << "\n";
  return s.str();
}

GrabReport GrabOneFrame(const std::string& robot_host,
                        int http_port,
                        const models::RobotConfig& robot,
                        const std::string& out_dir,
                        std::chrono::milliseconds timeout) {
  const HostPort hp = ParseHostPort(robot_host, kDefaultServoPort);
  MjpegClientOptions o;
  o.host = hp.host;
  o.port = http_port;
  o.swap_eyes = robot.swap_eyes;
  o.mirror_stream = robot.mirror_stream;
  o.connect_timeout = std::min(timeout, std::chrono::milliseconds(2000));
  o.expected_width = 2 * robot.image_width;  // checked before decoding
  o.expected_height = robot.image_height;
  MjpegClient client(o);
  const std::string url = "http://" + hp.host + ":" + std::to_string(http_port) + o.path;
  std::optional<MjpegFrame> f = client.Next(timeout);
  if (!f) {
    throw std::runtime_error(
        url + ": no frame within " + std::to_string(timeout.count()) + " ms (" +
        std::to_string(client.Stats().num_corrupt) + " corrupt, " + std::to_string(client.Stats().num_wrong_size) +
        " of the wrong size, " + std::to_string(client.Stats().num_failures) + " failed connections" +
        (client.Stats().last_problem.empty() ? "" : "; last: " + client.Stats().last_problem) + ")");
  }
  std::filesystem::create_directories(out_dir);
  GrabReport r;
  r.left_png = (std::filesystem::path(out_dir) / "left.png").string();
  r.right_png = (std::filesystem::path(out_dir) / "right.png").string();
  r.frame_jpg = (std::filesystem::path(out_dir) / "frame.jpg").string();
  r.width = f->stereo.left.cols + f->stereo.right.cols;
  r.height = f->stereo.left.rows;
  if (!cv::imwrite(r.left_png, f->stereo.left)) throw std::runtime_error(r.left_png + ": cannot write");
  if (!cv::imwrite(r.right_png, f->stereo.right)) throw std::runtime_error(r.right_png + ": cannot write");
  io::WriteFileAtomic(r.frame_jpg,
                      std::string_view(reinterpret_cast<const char*>(f->stereo.jpeg.data()), f->stereo.jpeg.size()));
  return r;
}

}  // namespace owlcal::robot
