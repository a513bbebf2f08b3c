// K-fold cross-validation over frames (declared in fitting/frame_cross_validation.h): the folds'
// fits in parallel, each held-out frame placed by its board pose alone, the pooled and per-fold
// held-out RMS, and the standard error of a difference between two candidates.
#include "fitting/frame_cross_validation.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/core/utility.hpp>

#include "fitting/board_warp.h"
#include "fitting/intrinsics_residual.h"

namespace owlcal::fitting::internal {
namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;

// Initial cam_from_target of a view through a fitted camera (solvePnP with its distortion).
bool InitialPose(const calib::View& v, const models::CameraIntrinsics& cam, models::Rigid3d* pose) {
  std::vector<cv::Point3d> op;
  std::vector<cv::Point2d> ip;
  for (size_t i = 0; i < v.pixels.size(); ++i) {
    op.emplace_back(v.points_in_target[i].x(), v.points_in_target[i].y(), v.points_in_target[i].z());
    ip.emplace_back(v.pixels[i].x(), v.pixels[i].y());
  }
  const cv::Mat k =
      (cv::Mat_<double>(3, 3) << cam.params[0], 0, cam.params[2], 0, cam.params[1], cam.params[3], 0, 0, 1);
  const std::vector<double> d = cam.Distortion();
  cv::Mat rvec, tvec;
  try {
    if (!cv::solvePnP(op, ip, k, cv::Mat(d, true).reshape(1, 1), rvec, tvec)) return false;
  } catch (const cv::Exception&) {
    return false;
  }
  if (tvec.at<double>(2) <= 0) return false;
  cv::Mat r;
  cv::Rodrigues(rvec, r);
  Eigen::Matrix3d re;
  cv::cv2eigen(r, re);
  *pose = models::Rigid3d(Eigen::Quaterniond(re),
                          Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  return true;
}

// Places one held-out frame by its board pose alone (cameras and right_from_left fixed) and
// returns its pixel errors. view[e] may be null (that eye did not see the frame). The pose is
// left cam_from_target when the left eye saw it, else right cam_from_target.
std::optional<FrameError> HeldOutError(const calib::View* view_in[2],
                                       const models::CameraIntrinsics cams[2],
                                       const models::Rigid3d& right_from_left,
                                       const double warp[2],
                                       const WarpSpan& span) {
  // The trained board bow (zero when not fitted) moves the held-out board's corners too.
  calib::View warped[2];
  const calib::View* view[2] = {nullptr, nullptr};
  for (int e = 0; e < 2; ++e) {
    if (!view_in[e]) continue;
    warped[e] = *view_in[e];
    for (auto& p : warped[e].points_in_target) p = WarpedPoint(warp, p, span);
    view[e] = &warped[e];
  }
  const int anchor = view[0] ? 0 : 1;
  models::Rigid3d pose;
  if (!InitialPose(*view[anchor], cams[anchor], &pose)) return std::nullopt;
  std::array<double, 7> p, ext;
  pose.ToArray(p.data());
  right_from_left.ToArray(ext.data());
  std::vector<double> cam[2] = {cams[0].params, cams[1].params};
  ceres::Problem::Options po;
  po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  PoseManifold manifold;
  problem.AddParameterBlock(p.data(), 7, &manifold);
  for (int e = 0; e < 2; ++e) {
    if (!view[e]) continue;
    problem.AddParameterBlock(cam[e].data(), int(cam[e].size()));
    problem.SetParameterBlockConstant(cam[e].data());
  }
  const bool via_ext = anchor == 0 && view[1];
  if (via_ext) {
    problem.AddParameterBlock(ext.data(), 7);
    problem.SetParameterBlockConstant(ext.data());
  }
  for (int e = 0; e < 2; ++e) {
    if (!view[e]) continue;
    const calib::View& v = *view[e];
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      if (e == 1 && via_ext) {
        ceres::CostFunction* c = models::VisitCameraModel(cams[1].model, [&]<typename Cam>() {
          return internal::StereoCornerResidual<Cam>::Create(v.pixels[i], v.points_in_target[i], 1.0, false);
        });
        problem.AddResidualBlock(c, nullptr, cam[1].data(), ext.data(), p.data());
      } else {
        ceres::CostFunction* c = models::VisitCameraModel(cams[e].model, [&]<typename Cam>() {
          return internal::CornerResidual<Cam>::Create(v.pixels[i], v.points_in_target[i], 1.0, false);
        });
        problem.AddResidualBlock(c, nullptr, cam[e].data(), p.data());
      }
    }
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = 50;
  so.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable()) return std::nullopt;
  FrameError fe;
  const models::Rigid3d placed = models::Rigid3d::Map(p.data());
  for (int e = 0; e < 2; ++e) {
    if (!view[e]) continue;
    const models::Rigid3d cam_from_target = (e == anchor) ? placed : right_from_left * placed;
    for (size_t i = 0; i < view[e]->pixels.size(); ++i) {
      const Eigen::Vector3d x = cam_from_target * view[e]->points_in_target[i];
      double px[2];
      if (!cams[e].Project(x.data(), px)) return std::nullopt;
      fe.sum_sq[e] += (Eigen::Vector2d(px[0], px[1]) - view[e]->pixels[i]).squaredNorm();
      ++fe.n[e];
    }
  }
  return fe;
}

}  // namespace

Trained TrainedOf(const StereoFit& f) {
  Trained t;
  t.ok = f.ok;
  t.message = f.message;
  if (!f.ok) return t;
  t.cams[0] = f.cameras[0];
  t.cams[1] = f.cameras[1];
  t.right_from_left = f.right_from_left;
  if (f.board_warp_fitted) {
    t.warp[0] = f.board_warp[0];
    t.warp[1] = f.board_warp[1];
  }
  return t;
}
void CrossValidate(const std::vector<calib::View>* views[2],
                   const std::vector<int>& frames,
                   int folds,
                   const TrainFn& train,
                   LensModelScore* score,
                   std::map<int, FrameError>* per_frame) {
  std::map<int, int> fold_of;
  for (size_t i = 0; i < frames.size(); ++i) fold_of[frames[i]] = int(i) % folds;
  std::vector<calib::View> all(views[0]->begin(), views[0]->end());
  all.insert(all.end(), views[1]->begin(), views[1]->end());
  const WarpSpan span = WarpSpanOfViews(all);
  double total_sq[2] = {0, 0};
  int total_n[2] = {0, 0};
  score->ok = true;
  // The folds' fits are independent single-threaded solves: they run at once (one per core),
  // and are read in fold order below, so the result does not depend on the thread count.
  std::vector<Trained> trained(folds);
  cv::parallel_for_(cv::Range(0, folds), [&](const cv::Range& r) {
    for (int k = r.start; k < r.end; ++k) {
      std::vector<calib::View> train_views[2];
      for (int e = 0; e < 2; ++e)
        for (const calib::View& v : *views[e])
          if (fold_of.at(v.frame_index) != k) train_views[e].push_back(v);
      try {
        trained[k] = train(train_views);
      } catch (const std::exception& ex) {
        trained[k].ok = false;
        trained[k].message = ex.what();
      }
    }
  });
  for (int k = 0; k < folds; ++k) {
    std::map<int, const calib::View*> held[2];
    for (int e = 0; e < 2; ++e)
      for (const calib::View& v : *views[e])
        if (fold_of.at(v.frame_index) == k) held[e][v.frame_index] = &v;
    const Trained& t = trained[k];
    if (!t.ok) {
      score->ok = false;
      score->message = "fold " + std::to_string(k + 1) + " of " + std::to_string(folds) + ": fit failed: " + t.message;
      return;
    }
    double fold_sq = 0;
    int fold_n = 0;
    for (size_t i = k; i < frames.size(); i += folds) {
      const int f = frames[i];
      const calib::View* v[2] = {held[0].count(f) ? held[0][f] : nullptr, held[1].count(f) ? held[1][f] : nullptr};
      const std::optional<FrameError> fe = HeldOutError(v, t.cams, t.right_from_left, t.warp, span);
      if (!fe) {
        score->ok = false;
        score->message = "fold " + std::to_string(k + 1) + ": held-out frame " + std::to_string(f) +
                         " could not be placed with the trained model";
        return;
      }
      (*per_frame)[f] = *fe;
      for (int e = 0; e < 2; ++e) {
        total_sq[e] += fe->sum_sq[e];
        total_n[e] += fe->n[e];
        fold_sq += fe->sum_sq[e];
        fold_n += fe->n[e];
      }
    }
    score->fold_rms_px.push_back(std::sqrt(fold_sq / std::max(1, fold_n)));
  }
  for (int e = 0; e < 2; ++e) score->heldout_rms_eye_px[e] = std::sqrt(total_sq[e] / std::max(1, total_n[e]));
  score->num_heldout_corners = total_n[0] + total_n[1];
  score->heldout_rms_px = std::sqrt((total_sq[0] + total_sq[1]) / std::max(1, score->num_heldout_corners));
}
std::vector<int> FramesOf(const std::vector<calib::View>* views[2]) {
  std::set<int> s;
  for (int e = 0; e < 2; ++e)
    for (const auto& v : *views[e]) s.insert(v.frame_index);
  return {s.begin(), s.end()};
}
double GainStandardError(const std::map<int, FrameError> per_frame[2], double rms0, double rms1) {
  // Mean-square difference per corner D = sum_f d_f / N, d_f = S0_f - S1_f; its standard error
  // from the spread of d_f - n_f D over frames; in RMS by the delta method.
  double sum_d = 0;
  int n = 0;
  for (const auto& [f, e0] : per_frame[0]) {
    const auto it = per_frame[1].find(f);
    if (it == per_frame[1].end()) continue;
    sum_d += e0.sum_sq[0] + e0.sum_sq[1] - it->second.sum_sq[0] - it->second.sum_sq[1];
    n += e0.n[0] + e0.n[1];
  }
  const double d_mean = sum_d / std::max(1, n);
  double var = 0;
  int num_frames = 0;
  for (const auto& [f, e0] : per_frame[0]) {
    const auto it = per_frame[1].find(f);
    if (it == per_frame[1].end()) continue;
    const double d = e0.sum_sq[0] + e0.sum_sq[1] - it->second.sum_sq[0] - it->second.sum_sq[1];
    const double r = d - (e0.n[0] + e0.n[1]) * d_mean;
    var += r * r;
    ++num_frames;
  }
  const double se_ms = num_frames > 1 ? std::sqrt(var * num_frames / (num_frames - 1)) / std::max(1, n) : NAN;
  return se_ms / std::max(1e-12, rms0 + rms1);
}

void CountFramesBetter(const std::map<int, FrameError> per_frame[2], int* better, int* compared) {
  *better = *compared = 0;
  for (const auto& [f, e0] : per_frame[0]) {
    const auto it = per_frame[1].find(f);
    if (it == per_frame[1].end()) continue;
    ++*compared;
    if (it->second.sum_sq[0] + it->second.sum_sq[1] < e0.sum_sq[0] + e0.sum_sq[1]) ++*better;
  }
}

bool HeldOutGainSignificant(double gain_px, double gain_se_px, int better, int compared) {
  const bool most_frames = compared > 0 && better > compared / 2.0 + std::sqrt(double(compared));
  return !std::isfinite(gain_se_px) || gain_px > 2 * gain_se_px || most_frames;
}

}  // namespace owlcal::fitting::internal
