#include "pipeline/sharpness_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <stdexcept>

#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "calib/observation_io.h"
#include "evaluation/range_images_ranging.h"
#include "evaluation/study_cells.h"
#include "io/json_strict.h"
#include "io/number_text.h"
#include "models/head_kinematics.h"
#include "pipeline/calibrate_pipeline.h"
#include "protocols/dataset.h"
#include "protocols/fixation.h"
#include "protocols/protocol.h"

namespace owlcal::pipeline {
namespace {

namespace fs = std::filesystem;

// The Owl's lens ahead of the neck axis: the eye's rotation centre 30 mm ahead
// (models::HeadGeometry) plus about 15 mm from there to the lens's centre of projection.
constexpr double kNominalCameraAheadM = 0.045;

// The course's 80x80 window at (280, 200) (data/owl-real/kit2020-distance-target1/README.md),
// grown about its centre for near targets (the box label's scale goes as 1 / distance).
cv::Rect DefaultWindow(double distance_m, const cv::Size& size) {
  const int side = std::max(80, int(std::lround(80 * 0.9 / distance_m)));
  const cv::Rect r(320 - side / 2, 240 - side / 2, side, side);
  return r & cv::Rect(0, 0, size.width, size.height);
}

// The bounding box of one eye's detected corners, grown by one square (the median spacing of
// neighbouring corners).
cv::Rect BoardBox(const std::vector<Eigen::Vector2d>& px, const cv::Size& size) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& p : px) {
    x0 = std::min(x0, p.x());
    y0 = std::min(y0, p.y());
    x1 = std::max(x1, p.x());
    y1 = std::max(y1, p.y());
  }
  // Square size ~ sqrt(area per corner).
  const double sq = std::sqrt(std::max(1.0, (x1 - x0) * (y1 - y0)) / std::max<size_t>(1, px.size()));
  const cv::Rect r(int(std::floor(x0 - sq)),
                   int(std::floor(y0 - sq)),
                   int(std::ceil(x1 - x0 + 2 * sq)),
                   int(std::ceil(y1 - y0 + 2 * sq)));
  return r & cv::Rect(0, 0, size.width, size.height);
}

// square_px > 0: the board's squares in the image; the edge window must hold one edge and the
// plateaus on both sides, not the next edge: probe_px <= (square - 3) / 2, at least 2 px (a
// window of +-2 px holds the edges of a board in focus, sigma ~0.3 px, to +-6 sigma).
void Measure(evaluation::SharpnessRow* row,
             const cv::Mat& image,
             const cv::Rect& roi,
             const evaluation::SharpnessOptions& o,
             double square_px = 0) {
  calib::EdgeSharpnessOptions eo = o.edge;
  if (square_px > 0) {
    eo.probe_px = std::min(eo.probe_px, (square_px - 3) / 2);
    if (eo.probe_px < 2) {
      row->status = "unmeasurable";
      row->reason = "the board's squares are " + evaluation::FxOrInf(square_px, 1) +
                    " px: too small for an edge window (at least 7 px)";
      row->sharpness.roi = roi;
      return;
    }
  }
  row->sharpness = calib::MeasureEdgeSharpness(image, roi, eo);
  if (row->sharpness.ok) {
    row->status = "ok";
  } else {
    row->status = "unmeasurable";
    row->reason = row->sharpness.reason;
  }
}

// Per eye: per distance means, then the focus fit.
void Summarise(evaluation::SharpnessStudy* s, const evaluation::SharpnessOptions& o) {
  for (int e = 0; e < 2; ++e) {
    std::map<double, std::vector<const evaluation::SharpnessRow*>> at;
    for (const evaluation::SharpnessRow& r : s->rows)
      if (r.eye == e) at[r.distance_m].push_back(&r);
    std::vector<fitting::FocusSample> samples;
    for (const auto& [d, rows] : at) {
      evaluation::SharpnessAtDistance a;
      a.distance_m = d;
      a.num_images = int(rows.size());
      double sum = 0, sum2 = 0, se2 = 0, lap = 0;
      for (const evaluation::SharpnessRow* r : rows) {
        if (r->status != "ok") continue;
        ++a.num_ok;
        sum += r->sharpness.blur_sigma_px;
        sum2 += r->sharpness.blur_sigma_px * r->sharpness.blur_sigma_px;
        se2 += r->sharpness.blur_sigma_se_px * r->sharpness.blur_sigma_se_px;
        lap += r->sharpness.laplacian_variance;
      }
      if (a.num_ok > 0) {
        const int n = a.num_ok;
        a.sigma_px = sum / n;
        a.laplacian_variance = lap / n;
        const double within = std::sqrt(se2) / n;  // the per-image errors, combined
        const double scatter = n > 1 ? std::sqrt(std::max(0.0, (sum2 - n * a.sigma_px * a.sigma_px) / (n - 1)) / n) : 0;
        a.se_px = std::max(within, scatter);
        samples.push_back({d, a.sigma_px, a.se_px});
      }
      s->by_distance[e].push_back(a);
    }
    s->fit[e] = fitting::FitFocus(samples, o.focus);
    if (!s->fit[e].ok)
      s->notes.push_back(std::string(models::kEyeNames[e]) + " eye: no focus fit: " + s->fit[e].reason);
    else if (!s->fit[e].focus_found)
      s->notes.push_back(std::string(models::kEyeNames[e]) + " eye: no defocus over " +
                         evaluation::FxOrInf(s->fit[e].min_distance_m, 2) + "-" +
                         evaluation::FxOrInf(s->fit[e].max_distance_m, 2) + " m (defocus " +
                         evaluation::FxOrInf(s->fit[e].k_px_per_dioptre, 3) + " +- " +
                         evaluation::FxOrInf(s->fit[e].k_sigma, 3) +
                         " px/D): the focus distance is not determined, everything measured is in focus");
  }
  for (const evaluation::SharpnessRow& r : s->rows) {
    if (r.status == "ok") {
      ++s->num_ok;
    } else {
      ++s->num_failed;
      s->notes.push_back(r.image + " (" + models::kEyeNames[r.eye] + ", " + evaluation::FxOrInf(r.distance_m, 2) +
                         " m): " + r.status + ": " + r.reason);
    }
  }
}

}  // namespace

evaluation::SharpnessStudy MeasureSharpnessDataset(const std::string& dir, const evaluation::SharpnessOptions& o) {
  evaluation::SharpnessStudy s;
  s.source = dir;
  const nlohmann::json manifest = protocols::ReadManifest(dir);
  const models::RobotConfig config = RobotConfigFromManifest(manifest, dir + "/manifest.json");
  // The protocol's chessboard (its size gives the "board fills the view" distance).
  calib::TargetDefinition board;
  bool have_board = false;
  if (manifest.contains("protocols"))
    for (const auto& p : manifest["protocols"]) {
      const protocols::Protocol proto = protocols::ParseProtocolYaml(p.value("text", ""), p.value("file", dir));
      if (auto it = proto.targets.find(proto.target);
          it != proto.targets.end() && it->second.kind == calib::TargetKind::kChessboard) {
        board = it->second;
        have_board = true;
      }
    }
  if (!have_board)
    throw std::runtime_error(dir + "/manifest.json: the sharpness study needs a protocol whose target is a chessboard");
  // A board the runner placed in a virtual scene stands at distance_m from the neck axis
  // (placements.csv, base frame); the lens is ahead of it by the eye centre's offset plus the
  // camera's offset from the eye's rotation centre. Boards a person placed are at the distance
  // the prompt asked for and the person measured: from the lens.
  double ahead_m[2] = {kNominalCameraAheadM, kNominalCameraAheadM};
  std::string ahead_source = "the nominal Owl head";
  if (manifest.contains("sim") && manifest["sim"].contains("truth_json") &&
      manifest["sim"]["truth_json"].contains("robot_truth")) {
    const nlohmann::json& t = manifest["sim"]["truth_json"]["robot_truth"];
    evaluation::SharpnessTruth truth;
    truth.aperture_mm = t["stream"].value("aperture_mm", 0.0);
    truth.focus_m = t["stream"].value("focus_m", 0.0);
    for (int e = 0; e < 2; ++e)
      truth.k_px_per_dioptre[e] =
          truth.aperture_mm * 1e-3 * t["cameras"][models::kEyeNames[e]]["params"][0].get<double>() / 4;
    if (truth.aperture_mm > 0) s.truth = truth;
    for (int e = 0; e < 2; ++e) {
      const nlohmann::json& g = t["geometry"][models::kEyeNames[e]];
      ahead_m[e] = g["centre_in_head_m"][2].get<double>() - g["cam_from_eye"]["t_m"][2].get<double>();
    }
    ahead_source = "the virtual Owl's head";
  }
  const std::vector<protocols::PlacementRecord> placements = protocols::ReadPlacementsCsv(dir);
  std::map<std::pair<int64_t, int>, std::vector<Eigen::Vector2d>> corners;
  if (fs::exists(dir + "/observations.csv"))
    for (const calib::CornerObservation& c : calib::ReadObservationsCsv(dir + "/observations.csv"))
      corners[{c.frame_index, c.eye}].push_back(c.pixel);
  std::map<int, std::string> kind_of;
  for (const protocols::StepRecord& r : protocols::ReadStepsCsv(dir)) kind_of[r.step_index] = r.kind;
  const double focal_px = protocols::NominalFocalPx(config);
  const Eigen::Vector4d extent = board.Extent();
  const double board_w_m = extent[1] - extent[0] + 2 * board.square_m;  // with the white margin
  for (const protocols::FrameRecord& f : protocols::ReadFramesCsv(dir)) {
    if (f.step_index < 0 || f.placement_index < 0 || f.placement_index >= int(placements.size())) continue;
    if (kind_of.count(f.step_index) == 0 || kind_of[f.step_index] != "capture") continue;  // moves, placements
    const protocols::PlacementRecord& pl = placements[size_t(f.placement_index)];
    const cv::Mat frame = cv::imdecode(protocols::ReadFrameJpeg(dir, f.frame_index), cv::IMREAD_COLOR);
    if (frame.empty()) throw std::runtime_error(protocols::FramePath(dir, f.frame_index) + ": not a decodable JPEG");
    cv::Mat eyes[2];
    calib::SplitStereoFrame(frame, config.mirror_stream, config.swap_eyes, &eyes[0], &eyes[1]);
    for (int e = 0; e < 2; ++e) {
      const double d = pl.source == "scene" ? pl.distance_m - ahead_m[e] : pl.distance_m;
      evaluation::SharpnessRow row;
      row.image = protocols::FramePath(dir, f.frame_index);
      row.frame_index = f.frame_index;
      row.eye = e;
      row.distance_m = d;
      const auto it = corners.find({f.frame_index, e});
      // The squares' size in the image: nominal focal length over the distance (the detected
      // corners would say the same within the board's tilt).
      const double square_px = focal_px * board.square_m / d;
      if (it != corners.end() && it->second.size() >= 4) {
        row.roi_source = "detected board";
        Measure(&row, eyes[e], BoardBox(it->second, eyes[e].size()), o, square_px);
      } else if (focal_px * board_w_m / d >= eyes[e].cols) {
        row.roi_source = "board fills the view";
        const cv::Size sz = eyes[e].size();
        Measure(&row, eyes[e], cv::Rect(sz.width / 4, sz.height / 4, sz.width / 2, sz.height / 2), o, square_px);
      } else {
        // Not detected while recording (its quick check gives up on small, low-contrast
        // boards): the full search of every command (classic, then sb).
        const calib::TargetDetection det = calib::DetectTarget(eyes[e], board, calib::DetectorOptions());
        if (det.found) {
          row.roi_source = "detected board";
          Measure(&row, eyes[e], BoardBox(det.pixels, eyes[e].size()), o, square_px);
        } else {
          row.status = "no target";
          row.reason =
              "the chessboard was not found (classic and sector-based detectors) and does not fill the view at " +
              evaluation::FxOrInf(d, 2) + " m";
        }
      }
      s.rows.push_back(row);
    }
  }
  if (s.rows.empty())
    throw std::runtime_error(dir + ": no capture frames with a placement (is this a sharpness recording?)");
  for (const protocols::PlacementRecord& pl : placements)
    if (pl.source == "scene") {
      s.notes.push_back("distances are from the lens: the scene's placements (from the neck axis) less " +
                        evaluation::FxOrInf(1e3 * ahead_m[0], 1) + " / " + evaluation::FxOrInf(1e3 * ahead_m[1], 1) +
                        " mm (left / right), from " + ahead_source);
      break;
    }
  Summarise(&s, o);
  return s;
}

std::vector<evaluation::SharpnessPair> ReadSharpnessPairsCsv(const std::string& path) {
  const fs::path base = fs::path(path).parent_path();
  std::vector<evaluation::SharpnessPair> out;
  for (const evaluation::RangeTruthRow& r : evaluation::ReadRangeTruthCsv(path)) {
    if (!std::isfinite(r.distance_m))
      throw std::runtime_error(r.where + ": the distance is blank (sharpness needs every distance)");
    evaluation::SharpnessPair p;
    p.left = fs::path(r.left).is_absolute() ? r.left : (base / r.left).string();
    p.right = fs::path(r.right).is_absolute() ? r.right : (base / r.right).string();
    p.distance_m = r.distance_m;
    p.roi = r.roi;
    out.push_back(p);
  }
  if (out.empty()) throw std::runtime_error(path + ": no image pairs");
  return out;
}

evaluation::SharpnessStudy MeasureSharpnessPairs(const std::vector<evaluation::SharpnessPair>& pairs,
                                                 const std::string& source,
                                                 const evaluation::SharpnessOptions& o) {
  evaluation::SharpnessStudy s;
  s.source = source;
  for (const evaluation::SharpnessPair& p : pairs) {
    for (int e = 0; e < 2; ++e) {
      evaluation::SharpnessRow row;
      row.image = e == 0 ? p.left : p.right;
      row.eye = e;
      row.distance_m = p.distance_m;
      const cv::Mat img = cv::imread(row.image, cv::IMREAD_GRAYSCALE);
      if (img.empty()) {
        row.status = "unreadable";
        row.reason = "not an image OpenCV can read";
      } else {
        row.roi_source = p.roi.area() > 0 ? "given" : "default window";
        Measure(&row, img, p.roi.area() > 0 ? p.roi : DefaultWindow(p.distance_m, img.size()), o);
      }
      s.rows.push_back(row);
    }
  }
  Summarise(&s, o);
  return s;
}

}  // namespace owlcal::pipeline
