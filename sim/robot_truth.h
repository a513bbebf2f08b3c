#pragma once
// The ground truth of one virtual Owl: what the robot-truth file (data/sim/*_truth.yaml)
// holds. Everything a calibration should recover is here, in the conventions of models/:
//   - servo maps as models::ServoMap params (centre_us, deg_per_us, quad_deg, cubic_deg,
//     hysteresis_us) + direction, so fitted numbers compare 1:1;
//   - head geometry (models/head_kinematics.h frames: base/head/eye/cam, cam_from_eye);
//   - intrinsics (models::CameraIntrinsics, OpenCV 5- or 8-coefficient distortion);
// plus what only a simulator needs: servo dynamics (dead band, PWM quantum, slew, lag,
// physical end-stops), the eye-socket rim, and the stream (fps, latency, JPEG, noise, drops).
//
// File format (YAML; every key below is required, so a file cut short or with a misspelt key is an
// error naming the file, line and field rather than a silent fall-back to the built-in robot;
// unknown and repeated keys, non-finite and out-of-range numbers are errors too, io/yaml_fields.h;
// the robot section gets the robot file's checks, robot/robot_file.h):
//   name: owl-default
//   robot:            # the robot file the course server was configured with (clamp limits)
//     name, ipd_m, image_width, image_height, swap_eyes, mirror_stream
//     servos: { Rx: {min_us, max_us, centre_us, direction, nominal_deg_per_us}, Ry: ..., ... }
//   servos:           # the physical truth per servo
//     Rx: {direction, centre_us, deg_per_us, quad_deg, cubic_deg, hysteresis_us,
//          dead_band_us, quantum_us, slew_deg_per_s, lag_s, endstop_lo_us, endstop_hi_us}
//   geometry:
//     left:  {centre_in_head_m: [x, y, z], cam_from_eye: {q_xyzw: [..4], t_m: [..3]}}
//     right: {...}
//   cameras:
//     left:  {model: opencv5|opencv8, width, height, params: [fx, fy, cx, cy, k1, k2, p1, p2, k3(, k4, k5, k6)]}
//     right: {...}
//   socket: {rim_half_angle_deg, rim_softness_deg, rim_floor}
//   stream: {fps, latency_ms, eye_offset_ms, jpeg_quality, noise_sigma, drop_probability,
//            servo_reply_ms, lens_shading, blur_px, white_level, black_level, rolling_shutter_ms,
//            aperture_mm, focus_m}
// Units as the suffixes say; angles in files are degrees, inside radians.
//
// Servo end-stops are given as the pulse width (approach 0) at which the joint meets its
// physical stop; the stop is an angle, so a larger command does not move the joint further.
// Dead band: a new pulse differing from the last accepted one by less than dead_band_us is
// ignored. Quantum: pulse widths are rounded to a multiple of quantum_us (1; pigpio's
// default sampling gives 5). Dynamics: a reference slews at slew_deg_per_s towards the
// commanded angle and the joint follows it with a first-order lag of time constant lag_s.
#include <array>
#include <string>

#include <nlohmann/json.hpp>

#include "models/camera_model.h"
#include "models/head_model.h"
#include "models/robot_config.h"
#include "models/servo_map.h"

namespace owlcal::sim {

struct ServoTruth {
  int direction = 1;
  double centre_us = 1500;
  double deg_per_us = 0.113;
  double quad_deg = 0;
  double cubic_deg = 0;
  double hysteresis_us = 0;
  double dead_band_us = 1;
  int quantum_us = 1;
  double slew_deg_per_s = 400;
  double lag_s = 0.025;
  double endstop_lo_us = 1000;  // pulse width where the physical stop is met (approach 0)
  double endstop_hi_us = 2000;

  // models::ServoMap parameter block: centre_us, deg_per_us, quad_deg, cubic_deg, hysteresis_us.
  std::array<double, models::ServoMap::kNumParams> MapParams() const {
    return {centre_us, deg_per_us, quad_deg, cubic_deg, hysteresis_us};
  }
  // Joint angle of the stops [rad], lo <= hi.
  double StopLoRad() const;
  double StopHiRad() const;
};

struct SocketTruth {
  double rim_half_angle_deg = 60;  // cone about the head's forward axis at each eye centre
  double rim_softness_deg = 4;     // the darkening ramps in over this angle
  double rim_floor = 0.08;         // brightness factor fully inside the rim
};

// Stream and image formation.
struct StreamTruth {
  double fps = 30;
  double latency_ms = 100;   // exposure -> frame received by the host
  double eye_offset_ms = 4;  // right eye exposes this much after the left
  int jpeg_quality = 85;
  double noise_sigma = 1.5;  // Gaussian sensor noise before JPEG [grey levels of 255]
  double drop_probability = 0;
  double servo_reply_ms = 1;      // round trip of one servo packet ("ok")
  double lens_shading = 0.2;      // relative brightness loss at the image corner
  double blur_px = 1.8;           // optical blur: footprint of the texture filter [px], >= 1
  double white_level = 215;       // grey level of white paper at the image centre (exposure)
  double black_level = 25;        // grey level of black ink
  double rolling_shutter_ms = 0;  // readout time from the top row to the bottom row
  // Defocus of the fixed-focus lens (thin lens, sim/renderer.h DefocusSigmaPx): a point at
  // depth z is spread over a disc of diameter aperture_mm * fx * |1/z - 1/focus_m| (fx in
  // this stream's pixels), on top of blur_px. The course notes (Annex 3a): f = 3.6 mm at
  // f/2.9, entrance pupil 1.25 mm, "in focus from approximately 28 cm to infinity", i.e.
  // focused at the hyperfocal distance, 2 x 0.28 m. aperture_mm = 0: no defocus.
  double aperture_mm = 1.25;
  double focus_m = 0.56;
};

struct RobotTruth {
  std::string name = "owl-default";
  models::RobotConfig robot;  // configured limits/centres (server clamp)
  std::array<ServoTruth, models::kNumServos> servos;
  models::HeadGeometry geometry;
  models::CameraIntrinsics intrinsics[2];  // [kLeftEye], [kRightEye]
  SocketTruth socket;
  StreamTruth stream;

  // The static truth as a models::HeadModel (servo maps, geometry, intrinsics).
  models::HeadModel HeadModel() const;
  // Throws std::invalid_argument naming the field and value when something is unphysical or the
  // robot section fails robot::ValidateRobotConfig.
  void Validate(const std::string& origin) const;
};

// cam_from_eye from the camera's optical centre in the eye frame [m] and a small rotation of the
// camera axes relative to the eye axes (rotation vector [deg]).
models::Rigid3d CamFromEyeMounting(const Eigen::Vector3d& cam_in_eye_m, const Eigen::Vector3d& rotvec_deg);

// Image formation of a typical real Owl, measured on the course's real sets (kit2020-chessboard,
// darvill2019 sessions 1-3; bench/sim_real_bench.cc prints the comparison): paper white ~160
// and ink ~60 grey levels, noise ~0.9 grey levels after JPEG, edges as sharp as a 0.53 px
// Gaussian, a quarter of the brightness lost at the image corners (lens shading 0.25: the real sets
// read 0.14-0.47 with one brightness per image, 0.46-0.53 with a light gradient per image besides;
// the Pi's ISP corrects only part of it), JPEG blocks like quality 95, a
// rolling shutter read out over 30 ms. The rest of the stream as the defaults. The default robot's
// stream (StreamTruth's own defaults are the older, cleaner ones that truth files written before
// the levels and the rolling shutter existed keep).
StreamTruth MeasuredOwlStream();

// The built-in default robot (same as data/sim/owl_default_truth.yaml): a typical real Owl, with
// MeasuredOwlStream()'s image formation.
RobotTruth DefaultRobotTruth();
// Reads a complete truth file. Throws std::runtime_error (std::invalid_argument from Validate)
// naming the path, line and field.
RobotTruth LoadRobotTruth(const std::string& path);
// YAML text of the whole truth (loadable by LoadRobotTruth) and its JSON form.
std::string RobotTruthYaml(const RobotTruth& truth);
nlohmann::json RobotTruthJson(const RobotTruth& truth);
void SaveRobotTruth(const RobotTruth& truth, const std::string& path);

}  // namespace owlcal::sim
