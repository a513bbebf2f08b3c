#include "calib/detector.h"

#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h11.h>
}

namespace owlcal::calib {
namespace {

// libapriltag 3.3 returns p[0..3] = bottom-left, bottom-right, top-right, top-left of the
// upright tag (counter-clockwise in a y-up view). Entry k is the libapriltag index of our
// corner k (0 TL, 1 TR, 2 BR, 3 BL); pinned by DetectorAprilTag.CornerOrderMatchesRenderedTag.
constexpr int kAprilIndexOfCorner[4] = {3, 2, 1, 0};

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

TargetDetection DetectChessboard(const cv::Mat& gray, const TargetDefinition& target, const DetectorOptions& o) {
  TargetDetection d;
  const cv::Size pattern(target.cols, target.rows);
  std::vector<cv::Point2f> corners;
  bool found = false;
  if (o.chessboard_method == ChessboardMethod::kClassic) {
    int flags = 0;
    if (o.adaptive_threshold) flags |= cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE;
    if (o.fast_check) flags |= cv::CALIB_CB_FAST_CHECK;
    found = cv::findChessboardCorners(gray, pattern, corners, flags);
    if (found) {
      cv::cornerSubPix(gray,
                       corners,
                       cv::Size(o.subpix_half_window, o.subpix_half_window),
                       cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS,
                                        o.subpix_max_iterations,
                                        o.subpix_epsilon_px));
    }
  } else {
    int flags = cv::CALIB_CB_NORMALIZE_IMAGE;
    if (o.sb_accuracy) flags |= cv::CALIB_CB_ACCURACY;
    if (o.sb_exhaustive) flags |= cv::CALIB_CB_EXHAUSTIVE;
    found = cv::findChessboardCornersSB(gray, pattern, corners, flags);
  }
  if (!found || int(corners.size()) != target.cols * target.rows) {
    d.message = "chessboard " + std::to_string(target.cols) + "x" + std::to_string(target.rows) + " not found";
    return d;
  }
  d.found = true;
  for (int i = 0; i < int(corners.size()); ++i) {
    d.corner_ids.push_back(i);
    d.pixels.emplace_back(corners[i].x, corners[i].y);
  }
  return d;
}

// One cached libapriltag detector per thread and family.
struct AprilDetector {
  apriltag_family_t* family = nullptr;
  apriltag_detector_t* detector = nullptr;
  void (*destroy_family)(apriltag_family_t*) = nullptr;
  ~AprilDetector() {
    if (detector) apriltag_detector_destroy(detector);
    if (family && destroy_family) destroy_family(family);
  }
};

AprilDetector& GetAprilDetector(const std::string& family_name, int max_hamming) {
  thread_local std::map<std::pair<std::string, int>, std::unique_ptr<AprilDetector>> cache;
  auto& slot = cache[{family_name, max_hamming}];
  if (!slot) {
    slot = std::make_unique<AprilDetector>();
    if (family_name == "tag36h11") {
      slot->family = tag36h11_create();
      slot->destroy_family = tag36h11_destroy;
    } else if (family_name == "tag25h9") {
      slot->family = tag25h9_create();
      slot->destroy_family = tag25h9_destroy;
    } else if (family_name == "tag16h5") {
      slot->family = tag16h5_create();
      slot->destroy_family = tag16h5_destroy;
    } else {
      throw std::invalid_argument("DetectTarget: AprilTag family '" + family_name + "' unsupported");
    }
    slot->detector = apriltag_detector_create();
    apriltag_detector_add_family_bits(slot->detector, slot->family, max_hamming);
    slot->detector->nthreads = 1;
  }
  return *slot;
}

TargetDetection DetectAprilGrid(const cv::Mat& gray, const TargetDefinition& target, const DetectorOptions& o) {
  TargetDetection d;
  AprilDetector& ad = GetAprilDetector(target.family, o.apriltag_max_hamming);
  ad.detector->quad_decimate = float(o.apriltag_decimate);
  ad.detector->quad_sigma = float(o.apriltag_blur_sigma);
  ad.detector->refine_edges = o.apriltag_refine_edges;
  cv::Mat g = gray.isContinuous() ? gray : gray.clone();
  image_u8_t im{g.cols, g.rows, int(g.step[0]), g.data};
  zarray_t* detections = apriltag_detector_detect(ad.detector, &im);
  const int num_tags = target.tag_cols * target.tag_rows;
  std::map<int, std::array<Eigen::Vector2d, 4>> tags;  // tag id -> our corners 0..3
  int dropped = 0;
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(detections, i, &det);
    if (det->id < target.first_id || det->id >= target.first_id + num_tags) {
      ++dropped;
      continue;
    }
    if (det->decision_margin < o.apriltag_min_margin || det->hamming > o.apriltag_max_hamming) {
      ++dropped;
      continue;
    }
    if (tags.count(det->id)) {  // the same id twice: ambiguous, drop both
      tags.erase(det->id);
      ++dropped;
      continue;
    }
    std::array<Eigen::Vector2d, 4> c;
    for (int k = 0; k < 4; ++k) {
      const int a = kAprilIndexOfCorner[k];
      // libapriltag: (0,0) at the top-left pixel's corner -> OpenCV: subtract 0.5 px.
      c[k] = Eigen::Vector2d(det->p[a][0] - 0.5, det->p[a][1] - 0.5);
    }
    tags[det->id] = c;
  }
  apriltag_detections_destroy(detections);
  if (int(tags.size()) < std::max(1, o.apriltag_min_tags)) {
    d.message = "aprilgrid: " + std::to_string(tags.size()) + " tags of the grid found (need " +
                std::to_string(std::max(1, o.apriltag_min_tags)) + ")";
    return d;
  }
  d.found = true;
  for (const auto& [id, c] : tags)
    for (int k = 0; k < 4; ++k) {
      d.corner_ids.push_back(4 * id + k);
      d.pixels.push_back(c[k]);
    }
  d.message = std::to_string(tags.size()) + " tags";
  if (dropped) d.message += ", " + std::to_string(dropped) + " other/ambiguous detections dropped";
  return d;
}

}  // namespace

bool DetectorOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "DetectorOptions." + m;
    return false;
  };
  if (subpix_half_window < 1 || subpix_half_window > 30)
    return fail("subpix_half_window must be 1..30, got " + std::to_string(subpix_half_window));
  if (subpix_max_iterations < 1) return fail("subpix_max_iterations must be >= 1, got " + std::to_string(subpix_max_iterations));
  if (!(subpix_epsilon_px > 0)) return fail("subpix_epsilon_px must be > 0, got " + std::to_string(subpix_epsilon_px));
  if (!(apriltag_decimate >= 1.0) || apriltag_decimate > 8)
    return fail("apriltag_decimate must be 1..8, got " + std::to_string(apriltag_decimate));
  if (apriltag_blur_sigma < 0) return fail("apriltag_blur_sigma must be >= 0, got " + std::to_string(apriltag_blur_sigma));
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
