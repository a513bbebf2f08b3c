// Independent checks of the virtual Owl's rendered geometry: OpenCV's chessboard detector
// and libapriltag find the corners where cv::projectPoints puts them from the exported truth.
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include <apriltag/apriltag.h>
#include <apriltag/tag36h11.h>
#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/virtual_owl.h"

namespace owlcal::sim {
namespace {

using models::kLeftEye;
using models::kRightEye;

VirtualOwlOptions NoiseFree() {
  VirtualOwlOptions o;
  o.seed = 3;
  o.noise_sigma = 0.0;
  return o;
}

// Truth pixels of a target's corners by cv::projectPoints (not the sim's own code).
std::vector<cv::Point2f> TruthCorners(const VirtualOwl& owl,
                                      const FrameTruth& ft,
                                      models::Eye eye,
                                      const std::string& target,
                                      std::vector<int>* ids = nullptr) {
  const models::HeadModel head = owl.TruthHeadModel();
  const SceneDescription scene = owl.SceneState();
  const SceneTarget* t = scene.Find(target);
  const Eigen::Matrix4d cam_from_target = ft.cam_from_base[eye].Matrix() * t->base_from_target.matrix();
  cv::Mat r(3, 3, CV_64F), rvec, tvec(3, 1, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) r.at<double>(i, j) = cam_from_target(i, j);
    tvec.at<double>(i) = cam_from_target(i, 3);
  }
  cv::Rodrigues(r, rvec);
  const auto& p = head.intrinsics[eye].params;
  const cv::Matx33d k(p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  std::vector<double> dist(p.begin() + 4, p.end());
  std::vector<cv::Point3f> obj;
  for (const auto& [id, flat] : t->definition.Corners()) {
    const Eigen::Vector3d x = t->WarpedPoint(flat);  // where the corner is on the (bowed) board
    obj.emplace_back(float(x.x()), float(x.y()), float(x.z()));
    if (ids) ids->push_back(id);
  }
  std::vector<cv::Point2f> img;
  cv::projectPoints(obj, rvec, tvec, k, dist, img);
  return img;
}

cv::Mat Grey(const cv::Mat& bgr) {
  cv::Mat g;
  cv::cvtColor(bgr, g, cv::COLOR_BGR2GRAY);
  return g;
}

void MaybeDump(const cv::Mat& img, const std::string& name) {
  if (const char* dir = std::getenv("OWLCAL_SIM_DUMP")) cv::imwrite(std::string(dir) + "/" + name + ".png", img);
}

// Detects the 9x6 board and returns the RMS distance to the truth corners [px]; `mean_offset`:
// the mean of (detected - truth) [px].
double ChessboardRms(const cv::Mat& grey,
                     const std::vector<cv::Point2f>& truth,
                     cv::Size size,
                     cv::Point2f* mean_offset = nullptr) {
  std::vector<cv::Point2f> found;
  if (!cv::findChessboardCorners(grey, size, found, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE))
    return -1;
  cv::cornerSubPix(grey,
                   found,
                   cv::Size(5, 5),
                   cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-4));
  if (found.size() != truth.size()) return -1;
  // The pattern is symmetric under a half turn: OpenCV may order it either way.
  if (cv::norm(found.front() - truth.front()) > cv::norm(found.front() - truth.back()))
    std::reverse(found.begin(), found.end());
  double sum = 0;
  cv::Point2f mean(0, 0);
  for (size_t i = 0; i < found.size(); ++i) {
    const cv::Point2f d = found[i] - truth[i];
    sum += d.dot(d);
    mean += d;
    if (std::getenv("OWLCAL_SIM_DEBUG"))
      std::printf("  corner %zu (%.1f %.1f) d %.3f %.3f\n", i, truth[i].x, truth[i].y, d.x, d.y);
  }
  mean /= float(found.size());
  std::printf("  mean offset %.4f %.4f px\n", mean.x, mean.y);
  if (mean_offset) *mean_offset = mean;
  return std::sqrt(sum / found.size());
}

struct BoardPose {
  Eigen::Vector3d centre;
  double yaw, pitch, roll;
};

TEST(RenderGeometry, ChessboardCornersMatchProjectPointsWithinATenthPixel) {
  VirtualOwl owl(NoiseFree());
  for (const std::string& n : owl.TargetNames())
    if (n != "chessboard") owl.SetTargetVisible(n, false);
  const calib::TargetDefinition def = owl.SceneState().Find("chessboard")->definition;
  const std::vector<BoardPose> poses = {{{0.0, 0.0, 0.63}, 0, 0, 0},
                                        {{0.05, -0.03, 0.55}, 25, 0, 5},
                                        {{-0.06, 0.04, 0.7}, -20, 15, -8},
                                        {{0.02, 0.02, 0.45}, 10, -25, 12}};
  double total = 0;
  cv::Point2f sum_mean(0, 0);
  int n = 0;
  int64_t after = 0;
  for (size_t i = 0; i < poses.size(); ++i) {
    const BoardPose& p = poses[i];
    owl.SetTargetPose("chessboard", FacingPose(def, p.centre, p.yaw, p.pitch, p.roll));
    auto frame = owl.GrabFrame(after, 1'000'000'000);
    ASSERT_TRUE(frame.has_value());
    after = frame->stamp_ns;
    const FrameTruth ft = owl.TruthForFrame(frame->seq);
    for (int e = 0; e < 2; ++e) {
      const auto eye = models::Eye(e);
      const cv::Mat img = Grey(e == kLeftEye ? frame->left : frame->right);
      MaybeDump(img, "chess_" + std::to_string(i) + "_" + models::kEyeNames[e]);
      cv::Point2f mean;
      const double rms =
          ChessboardRms(img, TruthCorners(owl, ft, eye, "chessboard"), cv::Size(def.cols, def.rows), &mean);
      std::printf("pose %zu %s eye: chessboard corner RMS vs projectPoints = %.4f px\n", i, models::kEyeNames[e], rms);
      ASSERT_GE(rms, 0) << "board not found, pose " << i << " eye " << e;
      // The default stream is a real Owl's: edges as sharp as a 0.53 px Gaussian, JPEG 95, ink and
      // paper 100 grey levels apart. cornerSubPix then errs 0.05-0.11 px per view (worst on the
      // fronto-parallel pose 0, whose corners line up with the pixel grid), 0.08 px over all:
      // the detector's floor, not geometry. A view's mean offset also carries the detector's
      // bias for where its corners fall between pixels: up to 0.034 px, and its sign flips when
      // the board moves 0.4 mm (pose 1, left eye). A misplaced render moves every view the same
      // way, so the geometry shows in the offset averaged over the views.
      EXPECT_LT(rms, 0.15) << "pose " << i << " eye " << e;
      EXPECT_LT(std::hypot(mean.x, mean.y), 0.05) << "pose " << i << " eye " << e;
      total += rms * rms;
      sum_mean += mean;
      ++n;
    }
  }
  std::printf("chessboard corner RMS over %d views: %.4f px, mean offset %.4f %.4f px\n",
              n,
              std::sqrt(total / n),
              sum_mean.x / n,
              sum_mean.y / n);
  EXPECT_LT(std::sqrt(total / n), 0.1);
  EXPECT_LT(std::hypot(sum_mean.x / n, sum_mean.y / n), 0.01);
}

TEST(RenderGeometry, AprilTagCornersMatchProjectPointsWithinTwoTenthsPixel) {
  VirtualOwl owl(NoiseFree());
  for (const std::string& n : owl.TargetNames())
    if (n != "aprilgrid") owl.SetTargetVisible(n, false);
  const calib::TargetDefinition def = owl.SceneState().Find("aprilgrid")->definition;
  apriltag_family_t* fam = tag36h11_create();
  apriltag_detector_t* det = apriltag_detector_create();
  apriltag_detector_add_family(det, fam);
  det->quad_decimate = 1;
  det->nthreads = 1;
  double sum = 0;
  int n = 0;
  int64_t after = 0;
  const std::vector<BoardPose> poses = {{{0.0, 0.0, 0.5}, 0, 0, 0}, {{0.03, 0.02, 0.45}, 20, -10, 6}};
  for (size_t pi = 0; pi < poses.size(); ++pi) {
    owl.SetTargetPose("aprilgrid", FacingPose(def, poses[pi].centre, poses[pi].yaw, poses[pi].pitch, poses[pi].roll));
    auto frame = owl.GrabFrame(after, 1'000'000'000);
    ASSERT_TRUE(frame.has_value());
    after = frame->stamp_ns;
    const FrameTruth ft = owl.TruthForFrame(frame->seq);
    for (int e = 0; e < 2; ++e) {
      const auto eye = models::Eye(e);
      cv::Mat img = Grey(e == kLeftEye ? frame->left : frame->right);
      MaybeDump(img, "april_" + std::to_string(pi) + "_" + models::kEyeNames[e]);
      std::vector<int> ids;
      const std::vector<cv::Point2f> truth = TruthCorners(owl, ft, eye, "aprilgrid", &ids);
      image_u8_t im = {img.cols, img.rows, int(img.step), img.data};
      zarray_t* detections = apriltag_detector_detect(det, &im);
      int found = 0;
      for (int i = 0; i < zarray_size(detections); ++i) {
        apriltag_detection_t* d;
        zarray_get(detections, i, &d);
        ++found;
        // libapriltag's corners have (0,0) at a pixel's corner: -0.5 px (docs/conventions.md, Facts).
        for (int c = 0; c < 4; ++c) {
          const cv::Point2f p(float(d->p[c][0] - 0.5), float(d->p[c][1] - 0.5));
          double best = 1e9;
          for (int k = 0; k < 4; ++k) {
            const size_t idx = std::find(ids.begin(), ids.end(), 4 * d->id + k) - ids.begin();
            ASSERT_LT(idx, ids.size()) << "tag id " << d->id << " is not on the board";
            best = std::min(best, double(cv::norm(p - truth[idx])));
          }
          EXPECT_LT(best, 1.0) << "tag " << d->id;
          sum += best * best;
          ++n;
        }
      }
      apriltag_detections_destroy(detections);
      std::printf(
          "pose %zu %s eye: %d of %d tags detected\n", pi, models::kEyeNames[e], found, def.tag_cols * def.tag_rows);
      EXPECT_GE(found, def.tag_cols * def.tag_rows * 3 / 4);
    }
  }
  apriltag_detector_destroy(det);
  tag36h11_destroy(fam);
  ASSERT_GT(n, 0);
  const double rms = std::sqrt(sum / n);
  std::printf("AprilTag corner RMS vs projectPoints over %d corners: %.4f px\n", n, rms);
  EXPECT_LT(rms, 0.2);
}

TEST(RenderGeometry, SocketRimDarkensTheBorderOnlyNearTheExtremes) {
  VirtualOwl owl(NoiseFree());
  const models::HeadModel head = owl.TruthHeadModel();
  models::JointAngles centre = head.Angles(owl.Config().Centre());
  models::JointAngles extreme = centre;
  extreme.pan_rad[kRightEye] = owl.Truth().servos[models::kRx].StopHiRad();
  const cv::Mat a = owl.RenderEyeGrey(kRightEye, centre);
  const cv::Mat b = owl.RenderEyeGrey(kRightEye, extreme);
  MaybeDump(b, "rim_right_extreme");
  // Looking far right, the socket rim covers the right border of the image.
  const double border_centre = cv::mean(a(cv::Rect(620, 0, 20, 480)))[0];
  const double border_extreme = cv::mean(b(cv::Rect(620, 0, 20, 480)))[0];
  std::printf("right border mean grey: centre %.1f, pan at stop %.1f\n", border_centre, border_extreme);
  EXPECT_GT(border_centre, 60);
  EXPECT_LT(border_extreme, 40);
  // The left border stays lit.
  EXPECT_GT(cv::mean(b(cv::Rect(0, 0, 20, 480)))[0], 60);
}

}  // namespace
}  // namespace owlcal::sim
