// Fit time and RMS of owlcal's Ceres fits against cv::calibrateCamera / cv::stereoCalibrate on
// the same observations (the OpenCV stereo sample set, corners from the default detector).
// Prints figures; asserts nothing.
#include <chrono>
#include <cstdio>
#include <cstdlib>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/detector.h"
#include "fitting/intrinsics_fit.h"
#include "fitting/stereo_fit.h"
#include "owlcal_version.h"

using namespace owlcal;

namespace {
double Now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
}  // namespace

int main() {
  const char* env = std::getenv("OWLCAL_SHARED_DATA");
  const std::string dir = std::string(env ? env : OWLCAL_SHARED_DATA) + "/opencv-stereo-chessboard/";
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
    std::printf("  intrinsics %-5s: owlcal %7.1f ms RMS %.4f fx %.2f | cv::calibrateCamera %7.1f ms RMS %.4f fx %.2f | "
                "time ratio %.2f\n",
                e == 0 ? "left" : "right", 1e3 * t_ow, fit.rms_px, fit.camera.params[0], 1e3 * t_cv, rms_cv,
                K.at<double>(0, 0), t_ow / t_cv);
  }
  {
    double t0 = Now(), rms_cv = 0;
    cv::Mat K1, D1, K2, D2, R, T, E, F;
    for (int r = 0; r < reps; ++r) {
      std::vector<cv::Mat> rv, tv;
      cv::calibrateCamera(op, ip[0], cv::Size(640, 480), K1, D1, rv, tv);
      cv::calibrateCamera(op, ip[1], cv::Size(640, 480), K2, D2, rv, tv);
      rms_cv = cv::stereoCalibrate(op, ip[0], ip[1], K1, D1, K2, D2, cv::Size(640, 480), R, T, E, F,
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
    std::printf("  stereo (incl. per-eye init): owlcal %7.1f ms RMS %.4f baseline %.4f | calibrateCamera x2 + "
                "stereoCalibrate %7.1f ms RMS %.4f baseline %.4f | time ratio %.2f\n",
                1e3 * t_ow, fit.rms_joint_px, fit.right_from_left.translation.norm(), 1e3 * t_cv, rms_cv, cv::norm(T),
                t_ow / t_cv);
    std::printf("  owlcal rectified |dy| mean %.4f max %.4f px; baseline sigma from covariance in the result file\n",
                fit.rectified_dy_mean_px, fit.rectified_dy_max_px);
  }
  return 0;
}
