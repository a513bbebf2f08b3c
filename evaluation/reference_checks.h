#pragma once
// Measured numbers against their references, for calibrate's report and results.json
// (diagnostics.reference_checks = {latency, alignment, field_of_view}):
//
//  - Latency: the latency protocol's reading per trial (command -> first received frame whose
//    image moved by threshold_px, protocols/latency_step.h) as mean and spread (sample standard
//    deviation over the trials), against the reading the virtual Owl's truth predicts for each
//    trial: the servo's slew and lag (models/slew_lag.h) give the time the image needs to move
//    threshold_px, the first exposure after that (frame grid seq / fps, the right eye
//    eye_offset_ms later, the image's middle row rolling_shutter_ms / 2 later) is received
//    latency_ms (+ a positive eye offset) after its exposure. The truth's stream latency alone
//    (exposure -> received) is given beside it: the reading adds the servo onset and the wait
//    for the next exposure. A real robot has no truth column.
//  - Alignment: roll and vertical offset between the eyes at the centre pose (alignment.csv),
//    mean and spread over the frames, with a verdict against a stated tolerance: a block matcher
//    searching along image rows (OpenCV StereoBM / SGBM, the course's disparity code on
//    unrectified images) tolerates about 1 px of vertical disparity, so |vertical offset| <= 1 px
//    and |roll| <= atan(1 px / (width / 2)) (1 px of vertical disparity at the image's side
//    edges: 0.18 deg at 640 px).
//  - Field of view and focal length of each fitted camera against the Pi camera datasheet in
//    the course notes (Annex 3: OV5647, 3.6 mm lens, 1.4 um pixels over 2592 x 1944; field of
//    view 53 x 40 deg): at an image width w the pixel pitch is 1.4 um * 2592 / w, so f = 634.9 px
//    at 640 px. The fitted FOV is the angle between the rays through the outer edges of the
//    image (lens model included); the pinhole FOV 2 atan(w / (2 f)) is given too. sigma comes
//    from the fit's covariance (the stereo fit's joint covariance of the eye's intrinsics when
//    present, else the per-parameter sigmas), by a numeric Jacobian.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fitting/result.h"
#include "models/head_model.h"

namespace owlcal::evaluation {

// ---- latency ----------------------------------------------------------------------------
struct LatencyTrial {
  int step_index = 0;
  int trial = 0;
  int servo = 0;  // models::ServoIndex
  int amplitude_us = 0;
  std::optional<double> latency_ms;  // the protocol's reading; nullopt: no motion seen
  // Newer datasets: when the step was sent (robot clock), its pulse widths, the motion threshold.
  std::optional<int64_t> command_ns;
  std::optional<int> from_us, to_us;
  std::optional<double> threshold_px;
};

// The virtual Owl's stream and servo dynamics as plain numbers (sim/robot_truth.h).
struct LatencyTruth {
  double fps = 30;
  double latency_ms = 100;   // exposure -> received
  double eye_offset_ms = 0;  // the right eye exposes this much after the left
  double rolling_shutter_ms = 0;
  double drop_probability = 0;
  std::array<double, models::kNumServos> slew_deg_per_s{};
  std::array<double, models::kNumServos> lag_s{};
  models::HeadModel head;  // true servo maps and intrinsics (not in the fit's gauge)
};

// The reading the truth predicts for one trial [ms]; nullopt (and why) when the trial lacks the
// newer columns or the true shift never passes the threshold.
std::optional<double> ExpectedLatencyReadingMs(const LatencyTruth& truth,
                                               const LatencyTrial& trial,
                                               std::string* why = nullptr);

struct LatencyGroup {
  std::string servo;  // "Rx", ..., or "all"
  int num_trials = 0, num_ok = 0;
  double mean_ms = NAN, sigma_ms = NAN, median_ms = NAN, min_ms = NAN, max_ms = NAN;
  // Virtual Owl only: the predicted readings' mean over the same trials, and the largest
  // |reading - prediction| of one trial.
  std::optional<double> truth_mean_ms;
  std::optional<double> max_abs_error_ms;
  int num_with_truth = 0;
  int num_on_predicted_frame = 0;  // |reading - prediction| < 1 ms (else a frame early or late:
                                   // the shift was near the threshold)
};

struct LatencyCheck {
  std::vector<LatencyGroup> groups;               // one per servo, then "all"
  std::optional<double> stream_latency_truth_ms;  // the truth's exposure -> received
  std::optional<double> fps;
  std::vector<std::string> notes;
};

LatencyCheck CheckLatency(const std::vector<LatencyTrial>& trials, const std::optional<LatencyTruth>& truth);

// ---- alignment --------------------------------------------------------------------------
struct AlignmentFrame {
  std::string method;  // chessboard | phase-correlation
  std::optional<double> roll_deg, vertical_offset_px, horizontal_offset_px;
};

struct AlignmentCheck {
  int num_frames = 0, num_roll = 0, num_vertical = 0;
  std::string method;  // of the frames used
  double roll_deg = NAN, roll_sigma_deg = NAN;
  double vertical_px = NAN, vertical_sigma_px = NAN;
  double horizontal_px = NAN;
  double tolerance_roll_deg = NAN, tolerance_vertical_px = NAN;
  std::string tolerance_source;
  std::string verdict;  // "within tolerance" | "outside tolerance" | "not measured"
  std::vector<std::string> advice;
};

// focal_px: the fitted (or nominal) focal length, for converting the offset to a tilt in us;
// deg_per_us: the tilt servos' scale (nominal 0.113).
AlignmentCheck CheckAlignment(const std::vector<AlignmentFrame>& frames,
                              int image_width,
                              double focal_px,
                              double deg_per_us);

// ---- field of view ----------------------------------------------------------------------
struct PiCameraDatasheet {
  double focal_mm = 3.6;
  double pixel_um = 1.4;
  int sensor_width_px = 2592, sensor_height_px = 1944;
  double hfov_deg = 53, vfov_deg = 40;  // the course notes' measured field of view
  std::string source =
      "course notes Annex 3a/3b: OV5647, 3.6 mm lens, 1.4 um pixels, 2592 x 1944, field of view 53 x 40 deg";
  double FocalPx(int image_width) const { return focal_mm / (pixel_um * 1e-3 * sensor_width_px / image_width); }
};

struct FovRow {
  std::string eye;
  double fx = NAN, fx_sigma = NAN, fy = NAN, fy_sigma = NAN;
  double hfov_deg = NAN, hfov_sigma_deg = NAN, vfov_deg = NAN, vfov_sigma_deg = NAN;  // image edges
  double pinhole_hfov_deg = NAN, pinhole_vfov_deg = NAN;
  double datasheet_f_px = NAN, datasheet_hfov_deg = NAN, datasheet_vfov_deg = NAN;
  std::optional<double> truth_fx, truth_hfov_deg, truth_vfov_deg;  // virtual Owl
};

struct FovCheck {
  std::vector<FovRow> rows;
  std::string source;
  std::vector<std::string> notes;
};

// The horizontal and vertical field of view through the image's outer edges [deg] (the rays
// through (-0.5, cy) and (w - 0.5, cy), and (cx, -0.5) and (cx, h - 0.5)).
std::array<double, 2> EdgeFovDeg(const models::CameraIntrinsics& camera);

// From result.cameras (and the stereo covariance or the parameters' sigmas); truth: the
// virtual Owl's intrinsics.
FovCheck CheckFieldOfView(const fitting::CalibrationResult& result,
                          const std::optional<std::array<models::CameraIntrinsics, 2>>& truth,
                          const PiCameraDatasheet& datasheet = {});

// ---- results.json -----------------------------------------------------------------------
nlohmann::json ToJson(const LatencyCheck& c);
nlohmann::json ToJson(const AlignmentCheck& c);
nlohmann::json ToJson(const FovCheck& c);

}  // namespace owlcal::evaluation
