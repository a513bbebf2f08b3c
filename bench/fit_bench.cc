// Fit time and RMS of owlcal's Ceres fits against cv::calibrateCamera / cv::stereoCalibrate on
// the same observations (the OpenCV stereo sample set, corners from the default detector).
// Prints figures; asserts nothing.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "fitting/board_synthetic.h"
#include "fitting/intrinsics_fit.h"
#include "fitting/stereo_fit.h"
#include "owlcal_version.h"
#include "sim/renderer.h"
#include "sim/scene.h"
#include "sim/virtual_owl.h"

using namespace owlcal;

namespace {
double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
}  // namespace

// Virtual Owl (default robot): the left eye sees the 9x6 chessboard at 20 poses; prints the
// detected-corner error against the true projection and the fitted fx, fy against the truth.
void VirtualOwlSection() {
  sim::VirtualOwl owl(sim::VirtualOwlOptions{});
  for (const std::string& n : owl.TargetNames())
    if (n != "chessboard") owl.SetTargetVisible(n, false);
  const auto scene = owl.SceneState();
  const sim::SceneTarget* board = scene.Find("chessboard");
  if (!board) {
    std::printf("  virtual Owl: default scene has no 'chessboard' target\n");
    return;
  }
  const calib::TargetDefinition def = board->definition;
  const models::CameraIntrinsics truth = owl.TruthHeadModel().intrinsics[models::kLeftEye];
  const models::JointAngles angles;  // all joints at zero
  const models::Rigid3d cam_from_base = owl.CamFromBase(models::kLeftEye, angles);
  const Eigen::Vector3d eye_in_base = cam_from_base.Inverse().translation;
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<calib::CornerObservation> obs;
  double err_sq = 0;
  int n_err = 0, found = 0;
  const double t0 = Now();
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d centre = eye_in_base + Eigen::Vector3d(0.07 * u(rng), 0.05 * u(rng), 0.42 + 0.1 * u(rng));
    const Eigen::Isometry3d base_from_target = sim::FacingPose(def, centre, 30 * u(rng), 30 * u(rng), 15 * u(rng));
    owl.SetTargetPose("chessboard", base_from_target);
    cv::Mat img = owl.RenderEyeGrey(models::kLeftEye, angles);
    sim::AddSensorNoise(&img, 2.0, 11, uint64_t(k));
    const calib::TargetDetection d = calib::DetectTarget(img, def, {});
    if (!d.found) continue;
    ++found;
    const auto corners = def.Corners();
    for (size_t i = 0; i < d.pixels.size(); ++i) {
      const Eigen::Vector3d p_base = base_from_target * corners.at(d.corner_ids[i]);
      const Eigen::Vector3d p_cam = cam_from_base * p_base;
      double px[2];
      if (!truth.Project(p_cam.data(), px)) continue;
      // OpenCV may number the board from either end; compare with the nearer end's corner.
      const Eigen::Vector3d p2 =
          cam_from_base * (base_from_target * corners.at(int(d.pixels.size()) - 1 - d.corner_ids[i]));
      double px2[2] = {px[0], px[1]};
      if (!truth.Project(p2.data(), px2)) px2[0] = px2[1] = 1e9;  // behind the camera: never the nearer
      const double e1 = (d.pixels[i] - Eigen::Vector2d(px[0], px[1])).squaredNorm();
      const double e2 = (d.pixels[i] - Eigen::Vector2d(px2[0], px2[1])).squaredNorm();
      err_sq += std::min(e1, e2);
      ++n_err;
    }
    auto o = calib::DetectionToObservations(d, def, k, 0);
    obs.insert(obs.end(), o.begin(), o.end());
  }
  std::printf("  virtual Owl left eye: board found in %d of 20 renders (%.0f ms), corner RMS error vs truth %.4f px\n",
              found,
              1e3 * (Now() - t0),
              std::sqrt(err_sq / std::max(1, n_err)));
  if (found < 3) return;
  const fitting::IntrinsicsFit fit = fitting::FitIntrinsics(calib::GroupIntoViews(obs), truth.width, truth.height, {});
  if (!fit.ok) {
    std::printf("  virtual Owl fit failed: %s\n", fit.message.c_str());
    return;
  }
  for (int i = 0; i < 4; ++i)
    std::printf("  virtual Owl %s = %.3f +- %.3f (truth %.3f, error %.3f %%, %.2f sigma)\n",
                fit.param_names[i].c_str(),
                fit.camera.params[i],
                fit.sigmas[i],
                truth.params[i],
                100 * (fit.camera.params[i] - truth.params[i]) / truth.params[i],
                (fit.camera.params[i] - truth.params[i]) / fit.sigmas[i]);
  std::printf("  virtual Owl fit RMS %.4f px\n", fit.rms_px);
}

// Honest sigma: 50 seeds of a synthetic 9x6 board seen in 15 random poses with
// 0.2 px corner noise; fraction of intrinsic parameters whose error is within 1 and 3 sigma.
void MonteCarloSection() {
  models::CameraIntrinsics truth;
  truth.params = {585.0, 583.0, 322.0, 236.0, -0.12, 0.08, 0.0008, -0.0005, -0.02};
  calib::TargetDefinition board;
  int within1 = 0, within3 = 0, total = 0, failed = 0;
  const double t0 = Now();
  for (int seed = 1; seed <= 50; ++seed) {
    std::mt19937 rng(seed);
    std::vector<calib::View> views;
    for (int k = 0; k < 15; ++k) {
      const models::Rigid3d pose = fitting::RandomBoardPose(board, {}, &rng);
      calib::View v = fitting::ProjectBoardView(truth, board, pose, 0.2, &rng);
      v.frame_index = k;
      views.push_back(v);
    }
    const fitting::IntrinsicsFit fit = fitting::FitIntrinsics(views, 640, 480, {});
    if (!fit.ok) {
      ++failed;
      continue;
    }
    for (size_t i = 0; i < truth.params.size(); ++i) {
      if (!fit.determined[i]) continue;
      const double z = std::abs(fit.camera.params[i] - truth.params[i]) / fit.sigmas[i];
      within1 += z <= 1;
      within3 += z <= 3;
      ++total;
    }
  }
  std::printf(
      "  Monte Carlo (50 seeds, 15 views, 0.2 px noise, sigma estimated): within 1 sigma %.1f %% (target 68 +- 7), "
      "within 3 sigma %.1f %% (target >= 98), %d parameters, %d failed fits, %.1f s\n",
      100.0 * within1 / std::max(1, total),
      100.0 * within3 / std::max(1, total),
      total,
      failed,
      Now() - t0);
}

int main() {
  const std::string dir = std::string(OWLCAL_DATA_DIR) + "/opencv-stereo-chessboard/";
  calib::TargetDefinition board;
  board.square_m = 1.0;
  std::vector<calib::CornerObservation> obs;
  std::vector<std::vector<cv::Point3f>> op;
  std::vector<std::vector<cv::Point2f>> ip[2];
  for (int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    calib::TargetDetection d[2];
    for (int e = 0; e < 2; ++e) {
      char name[32];
      std::snprintf(name, sizeof(name), "%s%02d.jpg", e == 0 ? "left" : "right", i);
      d[e] = calib::DetectTarget(cv::imread(dir + name, cv::IMREAD_GRAYSCALE), board, {});
    }
    if (!d[0].found || !d[1].found) continue;
    std::vector<cv::Point3f> o;
    for (int k = 0; k < 54; ++k) o.emplace_back(float(k % 9), float(k / 9), 0.f);
    op.push_back(o);
    for (int e = 0; e < 2; ++e) {
      std::vector<cv::Point2f> p;
      for (const auto& px : d[e].pixels) p.emplace_back(float(px.x()), float(px.y()));
      ip[e].push_back(p);
      const auto ob = calib::DetectionToObservations(d[e], board, i, e);
      obs.insert(obs.end(), ob.begin(), ob.end());
    }
  }
  if (op.empty()) {
    std::printf("fit_bench: no images in %s\n", dir.c_str());
    return 1;
  }
  const auto views = calib::GroupIntoViews(obs);
  std::vector<calib::View> eye_views[2];
  for (const auto& v : views) eye_views[v.eye].push_back(v);
  const int reps = 5;
  std::printf("fit_bench: %zu pairs of the OpenCV stereo set, %d repetitions each\n", op.size(), reps);

  for (int e = 0; e < 2; ++e) {
    double t0 = Now(), rms_cv = 0;
    cv::Mat K, D;
    for (int r = 0; r < reps; ++r) {
      std::vector<cv::Mat> rv, tv;
      rms_cv = cv::calibrateCamera(op, ip[e], cv::Size(640, 480), K, D, rv, tv);
    }
    const double t_cv = (Now() - t0) / reps;
    t0 = Now();
    fitting::IntrinsicsFit fit;
    for (int r = 0; r < reps; ++r) fit = fitting::FitIntrinsics(eye_views[e], 640, 480, {});
    const double t_ow = (Now() - t0) / reps;
    std::printf(
        "  intrinsics %-5s: owlcal %7.1f ms RMS %.4f fx %.2f | cv::calibrateCamera %7.1f ms RMS %.4f fx %.2f | "
        "time ratio %.2f\n",
        e == 0 ? "left" : "right",
        1e3 * t_ow,
        fit.rms_px,
        fit.camera.params[0],
        1e3 * t_cv,
        rms_cv,
        K.at<double>(0, 0),
        t_ow / t_cv);
  }
  {
    double t0 = Now(), rms_cv = 0;
    cv::Mat K1, D1, K2, D2, R, T, E, F;
    for (int r = 0; r < reps; ++r) {
      std::vector<cv::Mat> rv, tv;
      cv::calibrateCamera(op, ip[0], cv::Size(640, 480), K1, D1, rv, tv);
      cv::calibrateCamera(op, ip[1], cv::Size(640, 480), K2, D2, rv, tv);
      rms_cv = cv::stereoCalibrate(op,
                                   ip[0],
                                   ip[1],
                                   K1,
                                   D1,
                                   K2,
                                   D2,
                                   cv::Size(640, 480),
                                   R,
                                   T,
                                   E,
                                   F,
                                   cv::CALIB_USE_INTRINSIC_GUESS,
                                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5));
    }
    const double t_cv = (Now() - t0) / reps;
    t0 = Now();
    fitting::StereoFit fit;
    fitting::StereoFitOptions so;
    so.length_unit = "square";
    for (int r = 0; r < reps; ++r) fit = fitting::FitStereo(eye_views[0], eye_views[1], so);
    const double t_ow = (Now() - t0) / reps;
    std::printf(
        "  stereo (incl. per-eye init): owlcal %7.1f ms RMS %.4f baseline %.4f | calibrateCamera x2 + "
        "stereoCalibrate %7.1f ms RMS %.4f baseline %.4f | time ratio %.2f\n",
        1e3 * t_ow,
        fit.rms_joint_px,
        fit.right_from_left.translation.norm(),
        1e3 * t_cv,
        rms_cv,
        cv::norm(T),
        t_ow / t_cv);
    std::printf("  owlcal rectified |dy| mean %.4f max %.4f px; baseline sigma from covariance in the result file\n",
                fit.rectified_dy_mean_px,
                fit.rectified_dy_max_px);
  }
  MonteCarloSection();
  VirtualOwlSection();
  return 0;
}
