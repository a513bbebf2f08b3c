#pragma once
// Observations: one row per detected target corner. The contract between detection
// (calib/), recording (protocols/) and fitting (fitting/). Written to and read from CSV by
// calib/observation_io.h.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "models/robot_config.h"

namespace owlcal::calib {

struct CornerObservation {
  int frame_index = 0;                                // frame (image pair) in the dataset
  int eye = 0;                                        // models::kLeftEye / kRightEye
  std::string target_id;                              // which target (board) this corner is on
  int corner_id = 0;                                  // stable id on the target (partial views keep ids)
  Eigen::Vector2d pixel;                              // measured, OpenCV convention (pixel centres at integers)
  Eigen::Vector3d point_in_target;                    // the corner on the target [m]
  models::PwmVector pwm_us{};                         // servo command in force when the frame was taken
  std::array<int8_t, models::kNumServos> approach{};  // sign of the last move per servo (+1/-1/0)
  int64_t stamp_ns = 0;                               // frame receive time
};

// All corners of one eye in one frame, as fitting consumes them.
struct View {
  int frame_index = 0;
  int eye = 0;
  std::string target_id;
  models::PwmVector pwm_us{};
  std::array<int8_t, models::kNumServos> approach{};
  int64_t stamp_ns = 0;
  std::vector<int> corner_ids;
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector3d> points_in_target;
};

// Groups observations into views (frame, eye, target), preserving order.
std::vector<View> GroupIntoViews(const std::vector<CornerObservation>& obs);

}  // namespace owlcal::calib
