#include "sim/robot_truth.h"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <yaml-cpp/yaml.h>

#include "io/atomic_file.h"
#include "io/strict_number.h"
#include "io/yaml_fields.h"
#include "models/units.h"
#include "robot/robot_file.h"

namespace owlcal::sim {
namespace {

using models::kLeftEye;
using models::kNumServos;
using models::kRightEye;
using models::kServoNames;

}  // namespace

models::Rigid3d CamFromEyeMounting(const Eigen::Vector3d& cam_in_eye_m, const Eigen::Vector3d& rotvec_deg) {
  const Eigen::Vector3d w = rotvec_deg * kDeg;
  const Eigen::Quaterniond eye_from_cam_q =
      w.norm() > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(w.norm(), w.normalized())) : Eigen::Quaterniond::Identity();
  const models::Rigid3d eye_from_cam(eye_from_cam_q, cam_in_eye_m);
  return eye_from_cam.Inverse();
}

double ServoTruth::StopLoRad() const {
  const auto p = MapParams();
  const double a = models::ServoMap::JointAngle(p.data(), direction, endstop_lo_us, 0);
  const double b = models::ServoMap::JointAngle(p.data(), direction, endstop_hi_us, 0);
  return std::min(a, b);
}
double ServoTruth::StopHiRad() const {
  const auto p = MapParams();
  const double a = models::ServoMap::JointAngle(p.data(), direction, endstop_lo_us, 0);
  const double b = models::ServoMap::JointAngle(p.data(), direction, endstop_hi_us, 0);
  return std::max(a, b);
}

models::HeadModel RobotTruth::HeadModel() const {
  models::HeadModel h;
  for (int i = 0; i < kNumServos; ++i) {
    h.servo_params[i] = servos[i].MapParams();
    h.directions[i] = servos[i].direction;
  }
  h.geometry = geometry;
  h.intrinsics[0] = intrinsics[0];
  h.intrinsics[1] = intrinsics[1];
  return h;
}

void RobotTruth::Validate(const std::string& origin) const {
  auto fail = [&](const std::string& field, double value, const std::string& why) {
    std::ostringstream s;
    s << origin << ": " << field << " = " << value << ": " << why;
    throw std::invalid_argument(s.str());
  };
  // The robot section is a robot file in another spelling: the same checks.
  const std::string robot_why = robot::ValidateRobotConfig(robot);
  if (!robot_why.empty())
    throw std::invalid_argument(origin + ": robot section (checked as a robot file): " + robot_why);
  for (int i = 0; i < kNumServos; ++i) {
    const ServoTruth& s = servos[i];
    const std::string f = std::string("servos.") + kServoNames[i];
    if (s.direction != 1 && s.direction != -1) fail(f + ".direction", s.direction, "must be +1 or -1");
    if (!(s.deg_per_us > 0.01 && s.deg_per_us < 1)) fail(f + ".deg_per_us", s.deg_per_us, "must be in (0.01, 1)");
    if (s.hysteresis_us < 0) fail(f + ".hysteresis_us", s.hysteresis_us, "must be >= 0");
    if (s.dead_band_us < 0) fail(f + ".dead_band_us", s.dead_band_us, "must be >= 0");
    if (s.quantum_us < 1) fail(f + ".quantum_us", s.quantum_us, "must be >= 1");
    if (!(s.slew_deg_per_s > 0)) fail(f + ".slew_deg_per_s", s.slew_deg_per_s, "must be > 0");
    if (s.lag_s < 0) fail(f + ".lag_s", s.lag_s, "must be >= 0");
    if (!(s.endstop_lo_us < s.endstop_hi_us)) fail(f + ".endstop_lo_us", s.endstop_lo_us, "must be < endstop_hi_us");
    const auto p = s.MapParams();
    if (!models::ServoMap::IsMonotone(p.data(), s.direction, s.endstop_lo_us - 50, s.endstop_hi_us + 50)) {
      fail(f + ".cubic_deg", s.cubic_deg, "the map is not monotone over the end-stop range");
    }
    const models::ServoConfig& c = robot.servos[i];
    if (!(c.min_us <= c.centre_us && c.centre_us <= c.max_us)) {
      fail("robot.servos." + std::string(kServoNames[i]) + ".centre_us", c.centre_us, "outside min_us..max_us");
    }
  }
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics& k = intrinsics[e];
    const std::string f = std::string("cameras.") + models::kEyeNames[e];
    if (int(k.params.size()) != 4 + k.NumDistortion()) fail(f + ".params size", k.params.size(), "wrong for the model");
    if (!(k.params[0] > 0 && k.params[1] > 0)) fail(f + ".params[0] (fx)", k.params[0], "must be > 0");
    if (k.width != robot.image_width || k.height != robot.image_height) {
      fail(f + ".width", k.width, "must equal robot.image_width x image_height");
    }
  }
  if (!(stream.fps > 0 && stream.fps <= 240)) fail("stream.fps", stream.fps, "must be in (0, 240]");
  if (stream.latency_ms < 0) fail("stream.latency_ms", stream.latency_ms, "must be >= 0");
  if (stream.jpeg_quality < 1 || stream.jpeg_quality > 100)
    fail("stream.jpeg_quality", stream.jpeg_quality, "must be 1..100");
  if (stream.noise_sigma < 0) fail("stream.noise_sigma", stream.noise_sigma, "must be >= 0");
  if (stream.drop_probability < 0 || stream.drop_probability >= 1) {
    fail("stream.drop_probability", stream.drop_probability, "must be in [0, 1)");
  }
  if (std::abs(stream.eye_offset_ms) * 1e-3 * stream.fps >= 1)
    fail("stream.eye_offset_ms", stream.eye_offset_ms, "must be below one frame period");
  if (!(stream.blur_px >= 1 && stream.blur_px <= 8)) fail("stream.blur_px", stream.blur_px, "must be in [1, 8]");
  if (!(stream.black_level >= 0 && stream.black_level < stream.white_level && stream.white_level <= 255)) {
    fail("stream.white_level", stream.white_level, "must satisfy 0 <= black_level < white_level <= 255");
  }
  if (!(stream.rolling_shutter_ms >= 0 && stream.rolling_shutter_ms * 1e-3 * stream.fps <= 1)) {
    fail("stream.rolling_shutter_ms", stream.rolling_shutter_ms, "must be in [0, one frame period]");
  }
  if (!(stream.aperture_mm >= 0 && stream.aperture_mm <= 20))
    fail("stream.aperture_mm", stream.aperture_mm, "must be in [0, 20]");
  if (!(stream.focus_m > 0.01 && stream.focus_m <= 1e4))
    fail("stream.focus_m", stream.focus_m, "must be in (0.01, 10000]");
  if (!(socket.rim_half_angle_deg > 0 && socket.rim_half_angle_deg < 90)) {
    fail("socket.rim_half_angle_deg", socket.rim_half_angle_deg, "must be in (0, 90)");
  }
}

StreamTruth MeasuredOwlStream() {
  StreamTruth s;
  s.jpeg_quality = 95;
  s.noise_sigma = 1.0;
  s.lens_shading = 0.25;
  s.blur_px = 1.0;
  s.white_level = 160;
  s.black_level = 60;
  s.rolling_shutter_ms = 30;
  return s;
}

RobotTruth DefaultRobotTruth() {
  RobotTruth t;
  t.name = "owl-default";
  t.robot = models::DefaultRobotConfig();
  t.robot.name = "guide-owl";
  // Per-servo truth: centres within +-60 us of the configured ones, scales 8.3-9.4 us/deg,
  // a smooth nonlinearity, backlash; end-stops slightly beyond or inside the configured
  // limits (Ry top and Ly top are inside: commands there press against the stop).
  //                dir centre   deg/us  quad  cubic  hyst dead q slew  lag   stop_lo stop_hi
  t.servos[models::kRx] = {+1, 1562, 0.108, 0.6, -1.2, 2.0, 1, 1, 380, 0.025, 1185, 1905};
  t.servos[models::kRy] = {+1, 1498, 0.118, -0.5, 0.8, 1.5, 1, 1, 360, 0.030, 1110, 1985};
  t.servos[models::kLx] = {+1, 1521, 0.111, 0.4, 1.0, 2.5, 1, 1, 400, 0.025, 1170, 1860};
  t.servos[models::kLy] = {-1, 1617, 0.121, -0.7, -0.6, 1.8, 1, 1, 340, 0.030, 1190, 2010};
  t.servos[models::kNeck] = {-1, 1554, 0.106, 1.0, -1.5, 4.0, 3, 1, 300, 0.050, 1090, 1960};
  // Eye rotation centres: IPD 64.4 mm (0.6 mm under the robot file's 65, so a head fit that
  // leaves the IPD alone shows), ~30 mm ahead of the neck axis, slightly uneven.
  t.geometry.centre_in_head[kLeftEye] = Eigen::Vector3d(-0.0322, 0.0004, 0.0300);
  t.geometry.centre_in_head[kRightEye] = Eigen::Vector3d(0.0322, -0.0003, 0.0306);
  // Camera optical centres ~1.5 cm ahead of the rotation centres and 0.4 mm outward, rotated
  // 0.5-1 deg: the centre-pose baseline is then within the real Owls' 63.9-64.1 mm.
  t.geometry.cam_from_eye[kLeftEye] = CamFromEyeMounting({-0.0004, -0.0006, 0.0148}, {0.45, -0.60, 0.80});
  t.geometry.cam_from_eye[kRightEye] = CamFromEyeMounting({0.0004, 0.0009, 0.0162}, {-0.55, 0.35, -0.65});
  // Intrinsics near the measured real Owls (578-591 px), moderate barrel distortion.
  t.intrinsics[kLeftEye].params = {583.2, 582.4, 322.8, 236.1, -0.118, 0.092, 0.0008, -0.0005, -0.021};
  t.intrinsics[kRightEye].params = {587.9, 587.1, 317.4, 243.6, -0.104, 0.071, -0.0006, 0.0004, -0.016};
  // Image formation of a typical real Owl (bench/sim_real_bench.cc puts it beside the real sets).
  t.stream = MeasuredOwlStream();
  return t;
}

RobotTruth LoadRobotTruth(const std::string& path) {
  // Every key is required: a truth file describes a whole robot, so a missing key (a file cut
  // short, a typo) is an error rather than a silent fall-back to the built-in robot. Numbers are
  // bounded here to physical ranges; Validate() then checks how they relate.
  io::YamlFields f(io::LoadYamlFile(path, "robot-truth file"), path);
  RobotTruth t = DefaultRobotTruth();
  constexpr int kWide = 1000000;
  t.name = f.String("name");
  {
    io::YamlFields r = f.Map("robot");
    t.robot.name = r.String("name");
    t.robot.ipd_m = r.Number("ipd_m", -1e3, 1e3);
    t.robot.image_width = r.Int("image_width", -kWide, kWide);
    t.robot.image_height = r.Int("image_height", -kWide, kWide);
    t.robot.swap_eyes = r.Bool("swap_eyes");
    t.robot.mirror_stream = r.Bool("mirror_stream");
    io::YamlFields servos = r.Map("servos");
    for (int i = 0; i < kNumServos; ++i) {
      io::YamlFields s = servos.Map(kServoNames[i]);
      models::ServoConfig& c = t.robot.servos[i];
      c.min_us = s.Int("min_us", -kWide, kWide);
      c.max_us = s.Int("max_us", -kWide, kWide);
      c.centre_us = s.Int("centre_us", -kWide, kWide);
      c.direction = s.Int("direction", -kWide, kWide);
      c.nominal_deg_per_us = s.Number("nominal_deg_per_us", -1e3, 1e3);
      s.RejectUnknown();
    }
    servos.RejectUnknown();
    r.RejectUnknown();
  }
  {
    io::YamlFields servos = f.Map("servos");
    for (int i = 0; i < kNumServos; ++i) {
      io::YamlFields s = servos.Map(kServoNames[i]);
      ServoTruth& v = t.servos[i];
      v.direction = s.Int("direction", -1, 1);
      v.centre_us = s.Number("centre_us", 0, 9999);
      v.deg_per_us = s.Number("deg_per_us", 0, 1);
      v.quad_deg = s.Number("quad_deg", -90, 90);
      v.cubic_deg = s.Number("cubic_deg", -90, 90);
      v.hysteresis_us = s.Number("hysteresis_us", 0, 1000);
      v.dead_band_us = s.Number("dead_band_us", 0, 1000);
      v.quantum_us = s.Int("quantum_us", 1, 100);
      v.slew_deg_per_s = s.Number("slew_deg_per_s", 0, 1e5);
      v.lag_s = s.Number("lag_s", 0, 10);
      v.endstop_lo_us = s.Number("endstop_lo_us", 0, 9999);
      v.endstop_hi_us = s.Number("endstop_hi_us", 0, 9999);
      s.RejectUnknown();
    }
    servos.RejectUnknown();
  }
  {
    io::YamlFields geometry = f.Map("geometry");
    for (int e = 0; e < 2; ++e) {
      io::YamlFields g = geometry.Map(models::kEyeNames[e]);
      const auto c = g.Numbers("centre_in_head_m", 3, -1, 1);
      t.geometry.centre_in_head[e] = Eigen::Vector3d(c[0], c[1], c[2]);
      io::YamlFields p = g.Map("cam_from_eye");
      const auto q = p.Numbers("q_xyzw", 4, -1, 1);
      const Eigen::Quaterniond quat(q[3], q[0], q[1], q[2]);
      if (std::abs(quat.norm() - 1) > 1e-3) p.Fail("q_xyzw", "has norm " + io::FormatNumber(quat.norm()) + ", not 1");
      t.geometry.cam_from_eye[e].rotation = quat.normalized();
      const auto tr = p.Numbers("t_m", 3, -1, 1);
      t.geometry.cam_from_eye[e].translation = Eigen::Vector3d(tr[0], tr[1], tr[2]);
      p.RejectUnknown();
      g.RejectUnknown();
    }
    geometry.RejectUnknown();
  }
  {
    io::YamlFields cameras = f.Map("cameras");
    for (int e = 0; e < 2; ++e) {
      io::YamlFields k = cameras.Map(models::kEyeNames[e]);
      models::CameraIntrinsics& c = t.intrinsics[e];
      const std::string model = k.String("model");
      if (model == "opencv5")
        c.model = models::DistortionModel::kOpenCv5;
      else if (model == "opencv8")
        c.model = models::DistortionModel::kOpenCv8;
      else
        k.Fail("model", "= '" + io::Printable(model) + "' is not opencv5 or opencv8");
      c.width = k.Int("width", robot::kMinImageSide, robot::kMaxImageSide);
      c.height = k.Int("height", robot::kMinImageSide, robot::kMaxImageSide);
      c.params = k.Numbers("params", 4 + c.NumDistortion(), -1e5, 1e5);
      for (int j = 0; j < 2; ++j)
        if (!(c.params[j] > 0))
          k.Fail("params",
                 "[" + std::to_string(j) + "] (focal length) = " + io::FormatNumber(c.params[j]) + " must be > 0");
      for (int j = 4; j < static_cast<int>(c.params.size()); ++j)
        if (std::abs(c.params[j]) > 1e3)
          k.Fail("params",
                 "[" + std::to_string(j) + "] (distortion) = " + io::FormatNumber(c.params[j]) +
                     " is outside [-1000, 1000]");
      k.RejectUnknown();
    }
    cameras.RejectUnknown();
  }
  {
    io::YamlFields s = f.Map("socket");
    t.socket.rim_half_angle_deg = s.Number("rim_half_angle_deg", 0, 90);
    t.socket.rim_softness_deg = s.Number("rim_softness_deg", 0, 90);
    t.socket.rim_floor = s.Number("rim_floor", 0, 1);
    s.RejectUnknown();
  }
  {
    io::YamlFields s = f.Map("stream");
    t.stream.fps = s.Number("fps", 0, 240);
    t.stream.latency_ms = s.Number("latency_ms", 0, 10000);
    t.stream.eye_offset_ms = s.Number("eye_offset_ms", -1000, 1000);
    t.stream.jpeg_quality = s.Int("jpeg_quality", 1, 100);
    t.stream.noise_sigma = s.Number("noise_sigma", 0, 255);
    t.stream.drop_probability = s.Number("drop_probability", 0, 1);
    t.stream.servo_reply_ms = s.Number("servo_reply_ms", 0, 10000);
    t.stream.lens_shading = s.Number("lens_shading", 0, 1);
    t.stream.blur_px = s.Number("blur_px", 1, 8);
    // Image levels and the rolling shutter came later: files written before them keep the
    // defaults of StreamTruth (a clean, evenly exposed global shutter), whatever the default
    // robot's stream is.
    const StreamTruth older;
    t.stream.white_level = s.Number("white_level", older.white_level, 1, 255);
    t.stream.black_level = s.Number("black_level", older.black_level, 0, 254);
    t.stream.rolling_shutter_ms = s.Number("rolling_shutter_ms", older.rolling_shutter_ms, 0, 1000);
    // The lens's defocus came later still: older files have none (a pinhole's depth of field).
    t.stream.aperture_mm = s.Number("aperture_mm", 0.0, 0, 20);
    t.stream.focus_m = s.Number("focus_m", older.focus_m, 0.01, 1e4);
    s.RejectUnknown();
  }
  f.RejectUnknown();
  t.Validate(path);
  return t;
}

std::string RobotTruthYaml(const RobotTruth& t) {
  YAML::Emitter y;
  y.SetDoublePrecision(12);
  y << YAML::Comment("owlcal virtual Owl robot truth (format: sim/robot_truth.h)");
  y << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << t.name;
  y << YAML::Key << "robot" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "name" << YAML::Value << t.robot.name;
  y << YAML::Key << "ipd_m" << YAML::Value << t.robot.ipd_m;
  y << YAML::Key << "image_width" << YAML::Value << t.robot.image_width;
  y << YAML::Key << "image_height" << YAML::Value << t.robot.image_height;
  y << YAML::Key << "swap_eyes" << YAML::Value << t.robot.swap_eyes;
  y << YAML::Key << "mirror_stream" << YAML::Value << t.robot.mirror_stream;
  y << YAML::Key << "servos" << YAML::Value << YAML::BeginMap;
  for (int i = 0; i < kNumServos; ++i) {
    const models::ServoConfig& c = t.robot.servos[i];
    y << YAML::Key << kServoNames[i] << YAML::Value << YAML::Flow << YAML::BeginMap;
    y << YAML::Key << "min_us" << YAML::Value << c.min_us << YAML::Key << "max_us" << YAML::Value << c.max_us;
    y << YAML::Key << "centre_us" << YAML::Value << c.centre_us << YAML::Key << "direction" << YAML::Value
      << c.direction;
    y << YAML::Key << "nominal_deg_per_us" << YAML::Value << c.nominal_deg_per_us << YAML::EndMap;
  }
  y << YAML::EndMap << YAML::EndMap;
  y << YAML::Key << "servos" << YAML::Value << YAML::BeginMap;
  for (int i = 0; i < kNumServos; ++i) {
    const ServoTruth& s = t.servos[i];
    y << YAML::Key << kServoNames[i] << YAML::Value << YAML::Flow << YAML::BeginMap;
    y << YAML::Key << "direction" << YAML::Value << s.direction;
    y << YAML::Key << "centre_us" << YAML::Value << s.centre_us;
    y << YAML::Key << "deg_per_us" << YAML::Value << s.deg_per_us;
    y << YAML::Key << "quad_deg" << YAML::Value << s.quad_deg;
    y << YAML::Key << "cubic_deg" << YAML::Value << s.cubic_deg;
    y << YAML::Key << "hysteresis_us" << YAML::Value << s.hysteresis_us;
    y << YAML::Key << "dead_band_us" << YAML::Value << s.dead_band_us;
    y << YAML::Key << "quantum_us" << YAML::Value << s.quantum_us;
    y << YAML::Key << "slew_deg_per_s" << YAML::Value << s.slew_deg_per_s;
    y << YAML::Key << "lag_s" << YAML::Value << s.lag_s;
    y << YAML::Key << "endstop_lo_us" << YAML::Value << s.endstop_lo_us;
    y << YAML::Key << "endstop_hi_us" << YAML::Value << s.endstop_hi_us;
    y << YAML::EndMap;
  }
  y << YAML::EndMap;
  y << YAML::Key << "geometry" << YAML::Value << YAML::BeginMap;
  for (int e = 0; e < 2; ++e) {
    const Eigen::Vector3d& c = t.geometry.centre_in_head[e];
    const models::Rigid3d& p = t.geometry.cam_from_eye[e];
    y << YAML::Key << models::kEyeNames[e] << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "centre_in_head_m" << YAML::Value << YAML::Flow << std::vector<double>{c.x(), c.y(), c.z()};
    y << YAML::Key << "cam_from_eye" << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "q_xyzw" << YAML::Value << YAML::Flow
      << std::vector<double>{p.rotation.x(), p.rotation.y(), p.rotation.z(), p.rotation.w()};
    y << YAML::Key << "t_m" << YAML::Value << YAML::Flow
      << std::vector<double>{p.translation.x(), p.translation.y(), p.translation.z()};
    y << YAML::EndMap << YAML::EndMap;
  }
  y << YAML::EndMap;
  y << YAML::Key << "cameras" << YAML::Value << YAML::BeginMap;
  for (int e = 0; e < 2; ++e) {
    const models::CameraIntrinsics& k = t.intrinsics[e];
    y << YAML::Key << models::kEyeNames[e] << YAML::Value << YAML::BeginMap;
    y << YAML::Key << "model" << YAML::Value << (k.model == models::DistortionModel::kOpenCv5 ? "opencv5" : "opencv8");
    y << YAML::Key << "width" << YAML::Value << k.width << YAML::Key << "height" << YAML::Value << k.height;
    y << YAML::Key << "params" << YAML::Value << YAML::Flow << k.params;
    y << YAML::EndMap;
  }
  y << YAML::EndMap;
  y << YAML::Key << "socket" << YAML::Value << YAML::Flow << YAML::BeginMap;
  y << YAML::Key << "rim_half_angle_deg" << YAML::Value << t.socket.rim_half_angle_deg;
  y << YAML::Key << "rim_softness_deg" << YAML::Value << t.socket.rim_softness_deg;
  y << YAML::Key << "rim_floor" << YAML::Value << t.socket.rim_floor << YAML::EndMap;
  y << YAML::Key << "stream" << YAML::Value << YAML::BeginMap;
  y << YAML::Key << "fps" << YAML::Value << t.stream.fps;
  y << YAML::Key << "latency_ms" << YAML::Value << t.stream.latency_ms;
  y << YAML::Key << "eye_offset_ms" << YAML::Value << t.stream.eye_offset_ms;
  y << YAML::Key << "jpeg_quality" << YAML::Value << t.stream.jpeg_quality;
  y << YAML::Key << "noise_sigma" << YAML::Value << t.stream.noise_sigma;
  y << YAML::Key << "drop_probability" << YAML::Value << t.stream.drop_probability;
  y << YAML::Key << "servo_reply_ms" << YAML::Value << t.stream.servo_reply_ms;
  y << YAML::Key << "lens_shading" << YAML::Value << t.stream.lens_shading;
  y << YAML::Key << "blur_px" << YAML::Value << t.stream.blur_px;
  y << YAML::Key << "white_level" << YAML::Value << t.stream.white_level;
  y << YAML::Key << "black_level" << YAML::Value << t.stream.black_level;
  y << YAML::Key << "rolling_shutter_ms" << YAML::Value << t.stream.rolling_shutter_ms;
  y << YAML::Key << "aperture_mm" << YAML::Value << t.stream.aperture_mm;
  y << YAML::Key << "focus_m" << YAML::Value << t.stream.focus_m;
  y << YAML::EndMap;
  y << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

nlohmann::json RobotTruthJson(const RobotTruth& t) {
  using nlohmann::json;
  json j;
  j["name"] = t.name;
  json r;
  r["name"] = t.robot.name;
  r["ipd_m"] = t.robot.ipd_m;
  r["image_width"] = t.robot.image_width;
  r["image_height"] = t.robot.image_height;
  r["swap_eyes"] = t.robot.swap_eyes;
  r["mirror_stream"] = t.robot.mirror_stream;
  for (int i = 0; i < kNumServos; ++i) {
    const models::ServoConfig& c = t.robot.servos[i];
    r["servos"][kServoNames[i]] = {{"min_us", c.min_us},
                                   {"max_us", c.max_us},
                                   {"centre_us", c.centre_us},
                                   {"direction", c.direction},
                                   {"nominal_deg_per_us", c.nominal_deg_per_us}};
  }
  j["robot"] = r;
  for (int i = 0; i < kNumServos; ++i) {
    const ServoTruth& s = t.servos[i];
    j["servos"][kServoNames[i]] = {{"direction", s.direction},
                                   {"centre_us", s.centre_us},
                                   {"deg_per_us", s.deg_per_us},
                                   {"quad_deg", s.quad_deg},
                                   {"cubic_deg", s.cubic_deg},
                                   {"hysteresis_us", s.hysteresis_us},
                                   {"dead_band_us", s.dead_band_us},
                                   {"quantum_us", s.quantum_us},
                                   {"slew_deg_per_s", s.slew_deg_per_s},
                                   {"lag_s", s.lag_s},
                                   {"endstop_lo_us", s.endstop_lo_us},
                                   {"endstop_hi_us", s.endstop_hi_us},
                                   {"stop_lo_deg", s.StopLoRad() / kDeg},
                                   {"stop_hi_deg", s.StopHiRad() / kDeg}};
  }
  for (int e = 0; e < 2; ++e) {
    const Eigen::Vector3d& c = t.geometry.centre_in_head[e];
    const models::Rigid3d& p = t.geometry.cam_from_eye[e];
    j["geometry"][models::kEyeNames[e]] = {
        {"centre_in_head_m", {c.x(), c.y(), c.z()}},
        {"cam_from_eye",
         {{"q_xyzw", {p.rotation.x(), p.rotation.y(), p.rotation.z(), p.rotation.w()}},
          {"t_m", {p.translation.x(), p.translation.y(), p.translation.z()}}}}};
    const models::CameraIntrinsics& k = t.intrinsics[e];
    j["cameras"][models::kEyeNames[e]] = {
        {"model", k.model == models::DistortionModel::kOpenCv5 ? "opencv5" : "opencv8"},
        {"width", k.width},
        {"height", k.height},
        {"params", k.params}};
  }
  j["geometry"]["ipd_m"] = t.geometry.Ipd();
  j["socket"] = {{"rim_half_angle_deg", t.socket.rim_half_angle_deg},
                 {"rim_softness_deg", t.socket.rim_softness_deg},
                 {"rim_floor", t.socket.rim_floor}};
  j["stream"] = {{"fps", t.stream.fps},
                 {"latency_ms", t.stream.latency_ms},
                 {"eye_offset_ms", t.stream.eye_offset_ms},
                 {"jpeg_quality", t.stream.jpeg_quality},
                 {"noise_sigma", t.stream.noise_sigma},
                 {"drop_probability", t.stream.drop_probability},
                 {"servo_reply_ms", t.stream.servo_reply_ms},
                 {"lens_shading", t.stream.lens_shading},
                 {"blur_px", t.stream.blur_px},
                 {"white_level", t.stream.white_level},
                 {"black_level", t.stream.black_level},
                 {"rolling_shutter_ms", t.stream.rolling_shutter_ms},
                 {"aperture_mm", t.stream.aperture_mm},
                 {"focus_m", t.stream.focus_m}};
  return j;
}

void SaveRobotTruth(const RobotTruth& truth, const std::string& path) {
  const bool json = path.size() >= 5 && path.substr(path.size() - 5) == ".json";
  io::WriteFileAtomic(path, json ? RobotTruthJson(truth).dump(2) + "\n" : RobotTruthYaml(truth));
}

}  // namespace owlcal::sim
