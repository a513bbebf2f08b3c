#pragma once
// A student's stereo calibration set, taken on the virtual Owl the way the course's real sets
// were taken (data/owl-real/kit2020-chessboard, darvill2019-chessboard): the eyes stay at the
// robot file's centre, a person holds the chessboard at a new place for each pair, and each
// pair is cut from one stream frame and saved as left<k>.jpg / right<k>.jpg with OpenCV's
// default JPEG quality (95, what the course's cv::imwrite wrote).
//
// Board placement per pair (base frame, sim/scene.h): the board centre at a distance drawn
// uniformly in [distance_min_m, distance_max_m] and a direction inside the common field of view
// (lateral_fraction of the half field of view); tilted by a half-normal angle of sigma
// tilt_sigma_deg about a random axis in the board plane; rolled uniformly within +-roll_max_deg.
// A draw that leaves a corner outside either eye's image (margin_px) is drawn again. The board
// moves the way a held board does (SceneTarget::motion, when `hand_held`), so the two eyes,
// exposed eye_offset_ms apart, can see it at slightly different poses.
//
// Usage:
//   VirtualOwl owl({});
//   HandHeldCapture c = CaptureHandHeldSet(&owl, "/tmp/set", {});
//   // then fitting::MeasureCapture("virtual", "/tmp/set", {}, board)
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "sim/virtual_owl.h"

namespace owlcal::sim {

struct HandHeldCaptureOptions {
  std::string target = "chessboard";  // scene target to hold (others are hidden)
  int num_pairs = 27;
  double distance_min_m = 0.33;
  double distance_max_m = 0.70;
  double lateral_fraction = 0.75;
  double tilt_sigma_deg = 15;
  double roll_max_deg = 12;
  double margin_px = 4;
  bool hand_held = true;  // the board moves while it is held (TargetMotion)
  // RMS speeds of the held board, chosen so that the eyes' disagreement (pose jitter, stereo
  // RMS over per-eye RMS) matches the real sets (bench/sim_real_bench.cc).
  double held_speed_m_s = 0.06;
  double held_angular_speed_deg_s = 8.0;
  double settle_ms = 400;  // between placing the board and grabbing the pair
  int jpeg_quality = 95;
  uint64_t seed = 1;

  bool Check(std::string* why) const;
};

struct HandHeldCapture {
  std::vector<std::string> left_paths, right_paths;
  std::vector<Eigen::Isometry3d> base_from_target;  // the nominal placement of each pair
};

// Writes the pairs into out_dir (created). Throws std::invalid_argument for bad options or an
// unknown target, std::runtime_error naming the file when a write fails.
HandHeldCapture CaptureHandHeldSet(VirtualOwl* owl, const std::string& out_dir, const HandHeldCaptureOptions& options);

}  // namespace owlcal::sim
