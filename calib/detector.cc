#include "calib/detector.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/apriltag_free.h"

namespace owlcal::calib {
namespace {

cv::Mat ToGray(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("DetectTarget: empty image");
  cv::Mat gray;
  if (image.channels() == 3) {
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else if (image.channels() == 4) {
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  } else {
    gray = image;
  }
  if (gray.depth() != CV_8U) {
    cv::Mat g8;
    gray.convertTo(g8, CV_8U);
    gray = g8;
  }
  return gray;
}

// One detector at one pattern size (cols x rows as OpenCV counts them); true with every corner.
bool FindChessboard(const cv::Mat& gray,
                    const cv::Size& pattern,
                    ChessboardMethod method,
                    const DetectorOptions& o,
                    std::vector<cv::Point2f>* corners) {
  bool found = false;
  if (method == ChessboardMethod::kClassic) {
    int flags = 0;
    if (o.adaptive_threshold) flags |= cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
    if (o.fast_check) flags |= cv::CALIB_CB_FAST_CHECK;
    found = cv::findChessboardCorners(gray, pattern, *corners, flags);
    if (found) {
      cv::cornerSubPix(
          gray,
          *corners,
          cv::Size(o.subpix_half_window, o.subpix_half_window),
          cv::Size(-1, -1),
          cv::TermCriteria(
              cv::TermCriteria::COUNT + cv::TermCriteria::EPS, o.subpix_max_iterations, o.subpix_epsilon_px));
    }
  } else {
    int flags = cv::CALIB_CB_NORMALIZE_IMAGE;
    if (o.sb_accuracy) flags |= cv::CALIB_CB_ACCURACY;
    if (o.sb_exhaustive) flags |= cv::CALIB_CB_EXHAUSTIVE;
    found = cv::findChessboardCornersSB(gray, pattern, *corners, flags);
  }
  return found && int(corners->size()) == pattern.width * pattern.height;
}

// The detectors tried, in order (calib/detector.h: auto = classic then sb; fast_check = classic).
std::vector<ChessboardMethod> MethodsTried(const DetectorOptions& o) {
  if (o.fast_check) return {ChessboardMethod::kClassic};
  if (o.chessboard_method == ChessboardMethod::kAuto)
    return {ChessboardMethod::kClassic, ChessboardMethod::kSectorBased};
  return {o.chessboard_method};
}

TargetDetection DetectChessboard(const cv::Mat& gray, const TargetDefinition& target, const DetectorOptions& o) {
  TargetDetection d;
  const cv::Size pattern(target.cols, target.rows);
  const std::string size = std::to_string(target.cols) + "x" + std::to_string(target.rows);
  std::vector<std::string> tried;
  for (const ChessboardMethod m : MethodsTried(o)) {
    tried.push_back(ChessboardMethodName(m) + " " + size);
    std::vector<cv::Point2f> corners;
    if (!FindChessboard(gray, pattern, m, o, &corners)) continue;
    d.found = true;
    d.detector = tried.back();
    // sb numbers the corners from the other end of the board than classic (calib/detector.h):
    // reversed, so that a pair whose eyes were found by different detectors shares the ids.
    if (m == ChessboardMethod::kSectorBased) std::reverse(corners.begin(), corners.end());
    for (int i = 0; i < int(corners.size()); ++i) {
      d.corner_ids.push_back(i);
      d.pixels.emplace_back(corners[i].x, corners[i].y);
    }
    return d;
  }
  d.message = "chessboard " + size + " not found; tried";
  for (size_t i = 0; i < tried.size(); ++i) d.message += (i ? ", " : " ") + tried[i];
  d.message += " (each also accepts the board turned by 90 deg, " + std::to_string(target.rows) + "x" +
               std::to_string(target.cols) + ")";
  if (o.fast_check) d.message += "; with the fast check, which gives up on blurred or low-contrast boards";
  return d;
}

AprilTagOptions GridTagOptions(const std::string& family, const DetectorOptions& o) {
  AprilTagOptions ao;
  ao.families = {family};
  ao.quad_decimate = o.apriltag_decimate;
  ao.quad_sigma = o.apriltag_blur_sigma;
  ao.refine_edges = o.apriltag_refine_edges;
  ao.max_hamming = o.apriltag_max_hamming;
  std::string why;
  if (!ao.Check(&why)) throw std::invalid_argument("DetectTarget: " + why);
  return ao;
}

// The grid's tags among the image's detections of its family.
TargetDetection AprilGridFromTags(const std::vector<AprilTagDetection>& detections,
                                  const TargetDefinition& target,
                                  const DetectorOptions& o) {
  TargetDetection d;
  const int num_tags = target.tag_cols * target.tag_rows;
  // A grid id names one physical tag: an id seen more than once is ambiguous and every copy
  // is rejected (free-standing detection, calib/apriltag_free.h, keeps them all instead).
  std::map<int, std::array<Eigen::Vector2d, 4>> tags;  // tag id -> our corners 0..3
  std::set<int> repeated;
  int dropped = 0;
  for (const AprilTagDetection& t : detections) {
    if (t.family != target.family || t.id < target.first_id || t.id >= target.first_id + num_tags ||
        t.decision_margin < o.apriltag_min_margin) {
      ++dropped;
      continue;
    }
    if (t.repeated_id) {
      repeated.insert(t.id);
      continue;
    }
    tags[t.id] = t.corners;
  }
  if (int(tags.size()) < std::max(1, o.apriltag_min_tags)) {
    d.message = "aprilgrid: " + std::to_string(tags.size()) + " tags of the grid found (need " +
                std::to_string(std::max(1, o.apriltag_min_tags)) + ")";
    if (!repeated.empty()) d.message += "; " + std::to_string(repeated.size()) + " repeated ids rejected";
    return d;
  }
  d.found = true;
  for (const auto& [id, c] : tags)
    for (int k = 0; k < 4; ++k) {
      d.corner_ids.push_back(4 * id + k);
      d.pixels.push_back(c[k]);
    }
  d.message = std::to_string(tags.size()) + " tags";
  if (dropped) d.message += ", " + std::to_string(dropped) + " other or weak detections dropped";
  if (!repeated.empty()) {
    d.message += ", repeated ids rejected (every copy):";
    for (int id : repeated) d.message.append(" ").append(std::to_string(id));  // GCC 12 -Wrestrict on " " + s
  }
  return d;
}

TargetDetection DetectAprilGrid(const cv::Mat& gray, const TargetDefinition& target, const DetectorOptions& o) {
  return AprilGridFromTags(DetectAprilTags(gray, GridTagOptions(target.family, o)), target, o);
}

}  // namespace

std::string ChessboardMethodName(ChessboardMethod method) {
  switch (method) {
    case ChessboardMethod::kAuto:
      return "auto";
    case ChessboardMethod::kClassic:
      return "classic";
    case ChessboardMethod::kSectorBased:
      return "sb";
  }
  return "?";
}

bool DetectorOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "DetectorOptions." + m;
    return false;
  };
  if (subpix_half_window < 1 || subpix_half_window > 30)
    return fail("subpix_half_window must be 1..30, got " + std::to_string(subpix_half_window));
  if (subpix_max_iterations < 1)
    return fail("subpix_max_iterations must be >= 1, got " + std::to_string(subpix_max_iterations));
  if (!(subpix_epsilon_px > 0)) return fail("subpix_epsilon_px must be > 0, got " + std::to_string(subpix_epsilon_px));
  if (!(apriltag_decimate >= 1.0) || apriltag_decimate > 8)
    return fail("apriltag_decimate must be 1..8, got " + std::to_string(apriltag_decimate));
  if (apriltag_blur_sigma < 0)
    return fail("apriltag_blur_sigma must be >= 0, got " + std::to_string(apriltag_blur_sigma));
  if (apriltag_max_hamming < 0 || apriltag_max_hamming > 2)
    return fail("apriltag_max_hamming must be 0..2, got " + std::to_string(apriltag_max_hamming));
  if (apriltag_min_tags < 1) return fail("apriltag_min_tags must be >= 1, got " + std::to_string(apriltag_min_tags));
  return true;
}

TargetDetection DetectTarget(const cv::Mat& image, const TargetDefinition& target, const DetectorOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("DetectTarget: " + why);
  const cv::Mat gray = ToGray(image);
  switch (target.kind) {
    case TargetKind::kChessboard:
      return DetectChessboard(gray, target, options);
    case TargetKind::kAprilGrid:
      return DetectAprilGrid(gray, target, options);
    case TargetKind::kFixation:
      break;
  }
  throw std::invalid_argument("DetectTarget: target '" + target.id + "' is a fixation target; use calib/fixation_*");
}

std::vector<TargetDetection> DetectAprilGrids(const cv::Mat& image,
                                              const std::vector<TargetDefinition>& grids,
                                              const DetectorOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument("DetectAprilGrids: " + why);
  for (const TargetDefinition& g : grids)
    if (g.kind != TargetKind::kAprilGrid)
      throw std::invalid_argument("DetectAprilGrids: target '" + g.id + "' is not an aprilgrid");
  const cv::Mat gray = ToGray(image);
  std::map<std::string, std::vector<AprilTagDetection>> by_family;
  for (const TargetDefinition& g : grids)
    if (!by_family.count(g.family)) by_family[g.family] = DetectAprilTags(gray, GridTagOptions(g.family, options));
  std::vector<TargetDetection> out;
  for (const TargetDefinition& g : grids) out.push_back(AprilGridFromTags(by_family[g.family], g, options));
  return out;
}

std::vector<CornerObservation> DetectionToObservations(const TargetDetection& detection,
                                                       const TargetDefinition& target,
                                                       int frame_index,
                                                       int eye,
                                                       const models::PwmVector& pwm_us,
                                                       int64_t stamp_ns) {
  std::vector<CornerObservation> out;
  if (!detection.found) return out;
  const std::map<int, Eigen::Vector3d> corners = target.Corners();
  for (size_t i = 0; i < detection.corner_ids.size(); ++i) {
    auto it = corners.find(detection.corner_ids[i]);
    if (it == corners.end())
      throw std::invalid_argument("DetectionToObservations: corner id " + std::to_string(detection.corner_ids[i]) +
                                  " not on target '" + target.id + "'");
    CornerObservation o;
    o.frame_index = frame_index;
    o.eye = eye;
    o.target_id = target.id;
    o.corner_id = it->first;
    o.pixel = detection.pixels[i];
    o.point_in_target = it->second;
    o.pwm_us = pwm_us;
    o.stamp_ns = stamp_ns;
    out.push_back(o);
  }
  return out;
}

void SplitStereoFrame(const cv::Mat& frame, bool mirror, bool swap, cv::Mat* left, cv::Mat* right) {
  if (frame.empty() || frame.cols % 2 != 0)
    throw std::invalid_argument("SplitStereoFrame: frame width " + std::to_string(frame.cols) + " is not even");
  cv::Mat f;
  if (mirror) {
    cv::flip(frame, f, 1);  // into new storage: never flip the caller's frame in place
  } else {
    f = frame;
  }
  const int w = f.cols / 2;
  cv::Mat a = f(cv::Rect(0, 0, w, f.rows)).clone();
  cv::Mat b = f(cv::Rect(w, 0, w, f.rows)).clone();
  *left = swap ? b : a;
  *right = swap ? a : b;
}

}  // namespace owlcal::calib
