#include "fitting/lens_model_choice.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include <ceres/ceres.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/core/utility.hpp>

#include "fitting/board_warp.h"
#include "fitting/format.h"
#include "fitting/intrinsics_residual.h"

namespace owlcal::fitting {
namespace {

using PoseManifold = ceres::ProductManifold<ceres::EigenQuaternionManifold, ceres::EuclideanManifold<3>>;
using models::DistortionModel;

constexpr DistortionModel kCandidates[2] = {DistortionModel::kOpenCv5, DistortionModel::kOpenCv8};
// Solver tolerance of the fold refits: a held-out RMS needs 4 digits, not the final fit's 12.
constexpr double kRefitTolerance = 1e-8;

// The sums of one held-out frame: squared pixel errors and corners, per eye.
struct FrameError {
  double sum_sq[2] = {0, 0};
  int n[2] = {0, 0};
};

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

// The trained model a fold's held-out frames are placed with.
struct Trained {
  bool ok = false;
  std::string message;
  models::CameraIntrinsics cams[2];
  models::Rigid3d right_from_left;
  double warp[2] = {0, 0};  // the board's bow, when the fit fitted it
};

// What a stereo fit on the training folds gives the held-out frames.
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

// Runs the k-fold cross-validation of one model. views[e]: all views of eye e (views[1] empty
// for one camera). train(model, train_views) fits; returns the per-frame errors by frame.
template <typename TrainFn>
void CrossValidate(const std::vector<calib::View>* views[2],
                   const std::vector<int>& frames,
                   int folds,
                   TrainFn train,
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

// Frames (sorted, unique) over both eyes' views.
std::vector<int> FramesOf(const std::vector<calib::View>* views[2]) {
  std::set<int> s;
  for (int e = 0; e < 2; ++e)
    for (const auto& v : *views[e]) s.insert(v.frame_index);
  return {s.begin(), s.end()};
}

// The standard error of a held-out RMS difference between two candidates [px]: from the
// per-frame differences of the squared error sums (delta method).
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

// The choice from the two scores; fills gain, its standard error and the reason.
void Decide(const std::map<int, FrameError> per_frame[2], const LensModelChoiceOptions& o, LensModelChoice* c) {
  const LensModelScore& s5 = c->scores[0];
  const LensModelScore& s8 = c->scores[1];
  c->gain_px = s5.heldout_rms_px - s8.heldout_rms_px;
  c->gain_se_px = GainStandardError(per_frame, s5.heldout_rms_px, s8.heldout_rms_px);
  const bool gains = s8.heldout_rms_px < s5.heldout_rms_px * (1 - o.min_relative_gain);
  // More than noise: the gain must exceed twice its standard error (from the per-frame
  // differences). On 8 stereo views of robots of the prior (5-coefficient lenses) the rational
  // model had won on 12 of 30 robots by a gain of 1.0 standard error (one frame's extrapolation),
  // with k1 k2 k4 k5 undetermined and k3 "determined" up to 68 sigma from the truth.
  const bool significant = !std::isfinite(c->gain_se_px) || c->gain_px > 2 * c->gain_se_px;
  const bool richer = gains && significant;
  c->chosen = richer ? DistortionModel::kOpenCv8 : DistortionModel::kOpenCv5;
  c->chosen_name = DistortionModelName(c->chosen);
  std::ostringstream r;
  r << c->chosen_name << " chosen by " << c->folds << "-fold cross-validation over " << c->num_frames
    << " frames: held-out RMS opencv5 " << FixedOrDash(s5.heldout_rms_px, 4) << " px, opencv8 "
    << FixedOrDash(s8.heldout_rms_px, 4) << " px (difference " << FixedOrDash(c->gain_px, 4) << " +- "
    << FixedOrDash(c->gain_se_px, 4) << " px; fit RMS " << FixedOrDash(s5.fit_rms_px, 4) << " / "
    << FixedOrDash(s8.fit_rms_px, 4) << " px)";
  if (s8.heldout_rms_px >= s5.heldout_rms_px)
    r << "; the rational model predicts held-out views no better";
  else if (!gains)
    r << "; the rational model's gain is below the " + FixedOrDash(100 * o.min_relative_gain, 2) +
             " % a richer model must earn";
  else if (!significant)
    r << "; the rational model's gain is within twice its standard error";
  c->reason = r.str();
}

// Shared driver: `train(model, views)` returns a Trained; `full(model, score)` fits all views.
template <typename TrainFn, typename FullFn>
LensModelChoice Choose(const std::vector<calib::View>* views[2],
                       DistortionModel configured,
                       const LensModelChoiceOptions& o,
                       TrainFn train,
                       FullFn full) {
  const auto t0 = std::chrono::steady_clock::now();
  LensModelChoice c;
  c.chosen = configured;
  c.chosen_name = DistortionModelName(configured);
  std::string why;
  const std::vector<int> frames = FramesOf(views);
  c.num_frames = int(frames.size());
  if (!o.Check(&why)) {
    c.reason = "lens model not chosen (" + why + "): " + c.chosen_name + " as configured";
  } else if (!o.enabled) {
    c.reason = c.chosen_name + " as configured (cross-validation off)";
  } else if (c.num_frames < o.min_frames) {
    c.reason = c.chosen_name + " as configured: " + std::to_string(c.num_frames) +
               " frames are too few to cross-validate (at least " + std::to_string(o.min_frames) + ")";
  } else {
    c.folds = std::min(o.folds, c.num_frames);
    std::map<int, FrameError> per_frame[2];
    for (int m = 0; m < 2; ++m) {
      LensModelScore s;
      s.model = kCandidates[m];
      s.name = DistortionModelName(s.model);
      CrossValidate(
          views,
          frames,
          c.folds,
          [&](const std::vector<calib::View>* tv) { return train(s.model, tv); },
          &s,
          &per_frame[m]);
      full(&s);
      c.scores.push_back(std::move(s));
    }
    std::string failed;
    for (const auto& s : c.scores) {
      if (s.ok) continue;
      if (!failed.empty()) failed += "; ";
      failed += s.name + ": " + s.message;
    }
    if (failed.empty()) {
      c.cross_validated = true;
      Decide(per_frame, o, &c);
    } else {
      c.reason = c.chosen_name + " as configured: cross-validation failed (" + failed + ")";
    }
  }
  c.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

}  // namespace

bool LensModelChoiceOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "LensModelChoiceOptions." + m;
    return false;
  };
  if (folds < 2) return fail("folds must be >= 2, got " + std::to_string(folds));
  if (min_frames < folds) return fail("min_frames must be >= folds, got " + std::to_string(min_frames));
  if (!(min_relative_gain >= 0 && min_relative_gain < 0.5))
    return fail("min_relative_gain must be in [0, 0.5), got " + FixedOrDash(min_relative_gain, 4));
  return true;
}

const LensModelScore* LensModelChoice::Score(models::DistortionModel m) const {
  for (const auto& s : scores)
    if (s.model == m) return &s;
  return nullptr;
}

std::string DistortionModelName(models::DistortionModel m) {
  return m == DistortionModel::kOpenCv8 ? "opencv8" : "opencv5";
}

LensModelChoice ChooseStereoLensModel(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& choice) {
  const std::vector<calib::View>* views[2] = {&left_views, &right_views};
  auto opts = [&](DistortionModel m, bool covariance) {
    StereoFitOptions so = options;
    so.intrinsics.model = m;
    so.intrinsics.compute_covariance = covariance;
    if (!covariance) so.intrinsics.solver_tolerance = kRefitTolerance;
    return so;
  };
  auto train = [&](DistortionModel m, const std::vector<calib::View>* tv) {
    return TrainedOf(FitStereo(tv[0], tv[1], opts(m, false)));
  };
  auto full = [&](LensModelScore* s) {
    s->full = FitStereo(left_views, right_views, opts(s->model, options.intrinsics.compute_covariance));
    if (!s->full.ok) {
      s->ok = false;
      s->message = "fit on all views failed: " + s->full.message;
    }
    s->fit_rms_px = s->full.rms_joint_px;
  };
  return Choose(views, options.intrinsics.model, choice, train, full);
}

LensModelChoice ChooseIntrinsicsLensModel(const std::vector<calib::View>& views_in,
                                          int width,
                                          int height,
                                          const IntrinsicsFitOptions& options,
                                          const LensModelChoiceOptions& choice) {
  const std::vector<calib::View> none;
  const std::vector<calib::View>* views[2] = {&views_in, &none};
  auto opts = [&](DistortionModel m, bool covariance) {
    IntrinsicsFitOptions io = options;
    io.model = m;
    io.compute_covariance = covariance;
    if (!covariance) io.solver_tolerance = kRefitTolerance;
    return io;
  };
  auto train = [&](DistortionModel m, const std::vector<calib::View>* tv) {
    Trained t;
    const IntrinsicsFit f = FitIntrinsics(tv[0], width, height, opts(m, false));
    t.ok = f.ok;
    t.message = f.message;
    t.cams[0] = t.cams[1] = f.camera;
    return t;
  };
  auto full = [&](LensModelScore* s) {
    s->full_intrinsics = FitIntrinsics(views_in, width, height, opts(s->model, options.compute_covariance));
    if (!s->full_intrinsics.ok) {
      s->ok = false;
      s->message = "fit on all views failed: " + s->full_intrinsics.message;
    }
    s->fit_rms_px = s->full_intrinsics.rms_px;
  };
  return Choose(views, options.model, choice, train, full);
}

BoardWarpChoice ChooseStereoBoardWarp(const std::vector<calib::View>& left_views,
                                      const std::vector<calib::View>& right_views,
                                      const StereoFitOptions& options,
                                      const LensModelChoiceOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<calib::View>* views[2] = {&left_views, &right_views};
  BoardWarpChoice c;
  c.bowed = options.fit_board_warp;
  const std::vector<int> frames = FramesOf(views);
  c.num_frames = int(frames.size());
  const std::string configured = c.bowed ? "bowed" : "flat";
  std::string why;
  auto opts = [&](bool bowed, bool covariance) {
    StereoFitOptions so = options;
    so.fit_board_warp = bowed;
    so.intrinsics.compute_covariance = covariance;
    if (!covariance) so.intrinsics.solver_tolerance = kRefitTolerance;
    return so;
  };
  if (!o.Check(&why)) {
    c.reason = "board warp not chosen (" + why + "): " + configured + " as configured";
  } else if (!o.enabled) {
    c.reason = configured + " board as configured (cross-validation off)";
  } else if (c.num_frames < o.min_frames) {
    c.reason = configured + " board as configured: " + std::to_string(c.num_frames) +
               " frames are too few to cross-validate (at least " + std::to_string(o.min_frames) + ")";
  } else {
    c.folds = std::min(o.folds, c.num_frames);
    std::map<int, FrameError> per_frame[2];
    for (int bowed = 0; bowed < 2; ++bowed) {
      LensModelScore s;
      s.model = options.intrinsics.model;
      s.name = bowed ? "bowed" : "flat";
      CrossValidate(
          views,
          frames,
          c.folds,
          [&](const std::vector<calib::View>* tv) { return TrainedOf(FitStereo(tv[0], tv[1], opts(bowed, false))); },
          &s,
          &per_frame[bowed]);
      s.full = FitStereo(left_views, right_views, opts(bowed, options.intrinsics.compute_covariance));
      if (!s.full.ok) {
        s.ok = false;
        s.message = "fit on all views failed: " + s.full.message;
      }
      s.fit_rms_px = s.full.rms_joint_px;
      c.scores.push_back(std::move(s));
    }
    std::string failed;
    for (const auto& s : c.scores)
      if (!s.ok) failed += (failed.empty() ? "" : "; ") + s.name + ": " + s.message;
    if (!failed.empty()) {
      c.reason = configured + " board as configured: cross-validation failed (" + failed + ")";
    } else {
      c.cross_validated = true;
      const LensModelScore& flat = c.scores[0];
      const LensModelScore& bow = c.scores[1];
      c.gain_px = flat.heldout_rms_px - bow.heldout_rms_px;
      c.gain_se_px = GainStandardError(per_frame, flat.heldout_rms_px, bow.heldout_rms_px);
      c.bowed = bow.heldout_rms_px < flat.heldout_rms_px * (1 - o.min_relative_gain);
      for (int j = 0; j < 2; ++j) {
        c.warp[j] = bow.full.board_warp[j];
        c.warp_sigma[j] = bow.full.board_warp_sigma[j];
      }
      c.explained_fraction =
          1 - (bow.fit_rms_px * bow.fit_rms_px) / std::max(1e-300, flat.fit_rms_px * flat.fit_rms_px);
      c.heldout_explained_fraction =
          1 - (bow.heldout_rms_px * bow.heldout_rms_px) / std::max(1e-300, flat.heldout_rms_px * flat.heldout_rms_px);
      // The bow in mm for a metric target, else in the target's unit.
      const bool metres = options.length_unit == "m";
      const double scale = metres ? 1e3 : 1.0;
      const std::string unit = metres ? "mm" : options.length_unit;
      std::ostringstream r;
      r << (c.bowed ? "bowed" : "flat") << " board chosen by " << c.folds << "-fold cross-validation over "
        << c.num_frames << " frames: held-out RMS flat " << FixedOrDash(flat.heldout_rms_px, 4) << " px, bowed "
        << FixedOrDash(bow.heldout_rms_px, 4) << " px (difference " << FixedOrDash(c.gain_px, 4) << " +- "
        << FixedOrDash(c.gain_se_px, 4) << " px; fit RMS " << FixedOrDash(flat.fit_rms_px, 4) << " / "
        << FixedOrDash(bow.fit_rms_px, 4) << " px); bow x " << FixedOrDash(scale * c.warp[0], 3) << " +- "
        << FixedOrDash(scale * c.warp_sigma[0], 3) << ", y " << FixedOrDash(scale * c.warp[1], 3) << " +- "
        << FixedOrDash(scale * c.warp_sigma[1], 3) << " " << unit << ", explaining "
        << FixedOrDash(100 * c.explained_fraction, 3) << " % of the flat fit's squared residual ("
        << FixedOrDash(100 * c.heldout_explained_fraction, 3) << " % held out)";
      if (!c.bowed)
        r << (bow.heldout_rms_px < flat.heldout_rms_px
                  ? "; the bow's gain is below the " + FixedOrDash(100 * o.min_relative_gain, 2) +
                        " % a richer model must earn"
                  : "; the bow predicts held-out views no better");
      c.reason = r.str();
    }
  }
  c.time_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return c;
}

const LensModelScore* BoardWarpChoice::Chosen() const {
  if (!cross_validated || scores.size() != 2) return nullptr;
  return &scores[bowed ? 1 : 0];
}

nlohmann::json BoardWarpChoiceToJson(const BoardWarpChoice& c) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& s : c.scores)
    cands.push_back({{"board", s.name},
                     {"ok", s.ok},
                     {"message", s.message},
                     {"fit_rms_px", num(s.fit_rms_px)},
                     {"heldout_rms_px", num(s.heldout_rms_px)},
                     {"heldout_rms_left_px", num(s.heldout_rms_eye_px[0])},
                     {"heldout_rms_right_px", num(s.heldout_rms_eye_px[1])},
                     {"fold_rms_px", s.fold_rms_px},
                     {"num_heldout_corners", s.num_heldout_corners}});
  return {{"cross_validated", c.cross_validated},
          {"chosen", c.bowed ? "bowed" : "flat"},
          {"reason", c.reason},
          {"folds", c.folds},
          {"num_frames", c.num_frames},
          {"gain_px", num(c.gain_px)},
          {"gain_se_px", num(c.gain_se_px)},
          {"warp", {num(c.warp[0]), num(c.warp[1])}},
          {"warp_sigma", {num(c.warp_sigma[0]), num(c.warp_sigma[1])}},
          {"explained_fraction", num(c.explained_fraction)},
          {"heldout_explained_fraction", num(c.heldout_explained_fraction)},
          {"candidates", cands}};
}

void AppendBoardWarpChoiceToResult(const BoardWarpChoice& c, CalibrationResult* result) {
  result->diagnostics["board_warp_choice"] = BoardWarpChoiceToJson(c);
  result->inputs["board_warp"] = (c.cross_validated ? "auto: " : "") + c.reason;
}

nlohmann::json LensModelChoiceToJson(const LensModelChoice& c) {
  nlohmann::json cands = nlohmann::json::array();
  for (const auto& s : c.scores)
    cands.push_back({{"model", s.name},
                     {"ok", s.ok},
                     {"message", s.message},
                     {"fit_rms_px", s.fit_rms_px},
                     {"heldout_rms_px", s.heldout_rms_px},
                     {"heldout_rms_left_px", s.heldout_rms_eye_px[0]},
                     {"heldout_rms_right_px", s.heldout_rms_eye_px[1]},
                     {"fold_rms_px", s.fold_rms_px},
                     {"num_heldout_corners", s.num_heldout_corners}});
  return {{"cross_validated", c.cross_validated},
          {"chosen", c.chosen_name},
          {"reason", c.reason},
          {"folds", c.folds},
          {"num_frames", c.num_frames},
          {"gain_px", c.gain_px},
          {"gain_se_px", std::isfinite(c.gain_se_px) ? nlohmann::json(c.gain_se_px) : nlohmann::json()},
          {"candidates", cands}};
}

void AppendLensModelChoiceToResult(const LensModelChoice& c, CalibrationResult* result) {
  result->diagnostics["lens_model_choice"] = LensModelChoiceToJson(c);
  result->inputs["lens_model"] = (c.cross_validated ? "auto: " : "") + c.reason;
}

}  // namespace owlcal::fitting
