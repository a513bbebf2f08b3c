#pragma once
// The lens-sharpness experiment: edge blur against distance per eye, the fitted focus and depth
// of field, from a recorded `sharpness` protocol (protocols/standard/sharpness.yaml: a
// chessboard straight ahead at 0.2-2 m) or from image pairs at known distances (the course's
// kit2020 distance set).
//
// Per image (one row each, failures included):
//   - the region measured: the detected chessboard's corners (their bounding box grown by one
//     square) when the frame has a detection; else, when the board at that distance is wider
//     than the view (nominal focal length, protocols/fixation.h NominalFocalPx), the central
//     half of the image, which it covers; else the board re-detected (the recording's quick
//     check gives up on small, low-contrast boards: the full classic search, then the
//     sector-based detector); else the row is "no target". Image pairs carry their
//     own region (or the default, the course's 80x80 window at (280, 200) scaled up for near
//     targets).
//   - calib::MeasureEdgeSharpness on it: status "ok", or "unmeasurable" with its reason.
// Per eye and distance: the mean blur of the ok images with its standard error (the larger of
// the per-image errors combined and the scatter between images). Per eye: fitting::FitFocus
// over the distances (sigma(d)^2 = s0^2 + k^2 (1/d - 1/focus)^2) and the depth of field where
// the blur is at most sqrt 2 x the in-focus blur.
// Truth (virtual Owl, from the dataset's sim.truth_json): k = aperture * fx / 4 and the focus,
// with z = (fit - truth) / sigma.
//
// Outputs (WriteSharpnessStudy, OUT = the output folder):
//   OUT/tables/sharpness_images.{csv,md}    one row per image and eye (tidy: status, reason)
//   OUT/tables/sharpness.{csv,md,tex}       per eye and distance: n ok of N, blur, Laplacian variance
//   OUT/tables/sharpness_fit.{csv,md,tex}   per eye: in-focus blur, defocus, focus, depth of field (+ truth)
//   OUT/figures/sharpness.{png,svg,csv,gp}  blur vs distance per eye, the fits, the depth of field
//   OUT/sharpness.json                      all of it, machine-readable
//   OUT/report/index.html                   the page a student hands in
#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "calib/edge_sharpness.h"
#include "fitting/focus_fit.h"

namespace owlcal::evaluation {

struct SharpnessRow {
  std::string image;         // frame file (dataset) or image path
  int64_t frame_index = -1;  // dataset frame, -1 for image pairs
  int eye = 0;               // models::kLeftEye / kRightEye
  double distance_m = 0;
  std::string status;      // "ok", "no target", "unmeasurable"
  std::string reason;      // why not ok
  std::string roi_source;  // "detected board", "board fills the view", "given", "default window"
  calib::EdgeSharpness sharpness;
};

struct SharpnessAtDistance {
  double distance_m = 0;
  int num_ok = 0, num_images = 0;
  double sigma_px = 0, se_px = 0;  // mean blur of the ok images and its standard error
  double laplacian_variance = 0;   // mean over the ok images
};

struct SharpnessTruth {
  double focus_m = 0;                   // the lens's focus distance
  double k_px_per_dioptre[2] = {0, 0};  // aperture * fx / 4 per eye
  double aperture_mm = 0;
};

struct SharpnessStudy {
  std::string source;  // dataset folder or image folder
  std::vector<SharpnessRow> rows;
  std::array<std::vector<SharpnessAtDistance>, 2> by_distance;
  std::array<fitting::FocusFit, 2> fit;
  int num_ok = 0, num_failed = 0;
  std::optional<SharpnessTruth> truth;
  std::vector<std::string> notes;  // failures named, refused numbers
};

// One image pair at a known distance (left/right paths; roi empty = the default window).
struct SharpnessPair {
  std::string left, right;
  double distance_m = 0;
  cv::Rect roi;
};

struct SharpnessOptions {
  calib::EdgeSharpnessOptions edge;
  fitting::FocusFitOptions focus;
};

// The study as JSON (sharpness.json).
nlohmann::json SharpnessStudyJson(const SharpnessStudy& s);

}  // namespace owlcal::evaluation
