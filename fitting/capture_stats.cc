#include "fitting/capture_stats.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/chessboard_image_stats.h"
#include "calib/observation.h"
#include "fitting/intrinsics_fit.h"
#include "fitting/stereo_fit.h"

namespace owlcal::fitting {
namespace {

std::vector<unsigned char> ReadBytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return std::vector<unsigned char>(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Shared relative shading s over images by alternating least squares: grey = w_i (1 - s r^2),
// one brightness w_i per image; with `gradient`, grey = (w_i + a_i x + b_i y) (1 - s r^2), a
// linear light gradient across each image's board besides, so that s comes only from the
// brightness's curvature over each board (a lamp's gradient across a held board reads as
// shading to the first model: the board sits off-centre, where r^2 is nearly linear).
double FitShading(const std::vector<std::vector<calib::ChessboardImageStats::ShadingSample>>& per_image,
                  bool gradient) {
  const int m = gradient ? 3 : 1;
  double s = 0;
  std::vector<Eigen::Vector3d> light(per_image.size(), Eigen::Vector3d::Zero());
  auto basis = [&](const calib::ChessboardImageStats::ShadingSample& q) {
    return Eigen::Vector3d(1, gradient ? q.x : 0, gradient ? q.y : 0);
  };
  for (int it = 0; it < 50; ++it) {
    for (size_t i = 0; i < per_image.size(); ++i) {
      Eigen::Matrix3d ata = Eigen::Matrix3d::Zero();
      Eigen::Vector3d atb = Eigen::Vector3d::Zero();
      for (const auto& q : per_image[i]) {
        const Eigen::Vector3d row = (1 - s * (q.x * q.x + q.y * q.y)) * basis(q);
        ata += row * row.transpose();
        atb += row * q.grey;
      }
      light[i].setZero();
      if (int(per_image[i].size()) < 2 * m) continue;
      light[i].head(m) = ata.topLeftCorner(m, m).ldlt().solve(atb.head(m));
    }
    double num = 0, den = 0;
    for (size_t i = 0; i < per_image.size(); ++i)
      for (const auto& q : per_image[i]) {
        const double l = light[i].dot(basis(q)), r2 = q.x * q.x + q.y * q.y;
        if (l == 0) continue;
        num += r2 * l * (l - q.grey);
        den += r2 * l * r2 * l;
      }
    if (den <= 0) return 0;
    s = num / den;
  }
  return s;
}

// Board pose of one view with given intrinsics (cv::solvePnP, iterative).
std::optional<models::Rigid3d> PosePnP(const calib::View& v, const models::CameraIntrinsics& cam) {
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (size_t i = 0; i < v.pixels.size(); ++i) {
    obj.emplace_back(v.points_in_target[i].x(), v.points_in_target[i].y(), v.points_in_target[i].z());
    img.emplace_back(v.pixels[i].x(), v.pixels[i].y());
  }
  const cv::Mat k =
      (cv::Mat_<double>(3, 3) << cam.params[0], 0, cam.params[2], 0, cam.params[1], cam.params[3], 0, 0, 1);
  const std::vector<double> d = cam.Distortion();
  cv::Mat rvec, tvec;
  try {
    if (!cv::solvePnP(obj, img, k, cv::Mat(d, true), rvec, tvec, false, cv::SOLVEPNP_ITERATIVE)) return std::nullopt;
  } catch (const cv::Exception&) {
    return std::nullopt;
  }
  cv::Mat rm;
  cv::Rodrigues(rvec, rm);
  Eigen::Matrix3d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = rm.at<double>(i, j);
  return models::Rigid3d(Eigen::Quaterniond(r),
                         Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
}

}  // namespace

Eigen::Vector2d FitBoardWarp(const std::vector<calib::View>& views,
                             const calib::TargetDefinition& target,
                             int width,
                             int height,
                             double* rms_px) {
  // Corner grid span (the warp's u, v in [-1, 1]).
  double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
  for (const auto& [id, p] : target.Corners()) {
    x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x()), y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
  }
  auto rms_at = [&](const Eigen::Vector2d& k) {
    std::vector<calib::View> v = views;
    for (auto& view : v)
      for (auto& p : view.points_in_target) {
        const double u = (p.x() - (x0 + x1) / 2) / std::max(1e-12, (x1 - x0) / 2);
        const double w = (p.y() - (y0 + y1) / 2) / std::max(1e-12, (y1 - y0) / 2);
        p.z() = -(k.x() * (1 - u * u) + k.y() * (1 - w * w));
      }
    IntrinsicsFitOptions io;
    const IntrinsicsFit f = FitIntrinsics(v, width, height, io);
    return f.ok ? f.rms_px : std::numeric_limits<double>::infinity();
  };
  Eigen::Vector2d best = Eigen::Vector2d::Zero();
  double best_rms = rms_at(best);
  for (const double step : {1e-3, 0.25e-3, 0.0625e-3}) {
    const Eigen::Vector2d centre = best;
    for (int i = -2; i <= 2; ++i)
      for (int j = -2; j <= 2; ++j) {
        if (i == 0 && j == 0) continue;
        const Eigen::Vector2d k = centre + step * Eigen::Vector2d(i, j);
        const double r = rms_at(k);
        if (r < best_rms) best_rms = r, best = k;
      }
  }
  if (rms_px) *rms_px = best_rms;
  return best;
}

Spread SpreadOf(std::vector<double> v) {
  Spread s;
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  s.count = int(v.size());
  if (v.empty()) {
    s.p10 = s.median = s.p90 = s.mean = s.stddev = std::nan("");
    return s;
  }
  std::sort(v.begin(), v.end());
  auto pct = [&](double p) {
    const double k = p * (v.size() - 1);
    const size_t a = size_t(std::floor(k)), b = std::min(v.size() - 1, a + 1);
    return v[a] + (k - a) * (v[b] - v[a]);
  };
  s.p10 = pct(0.1);
  s.median = pct(0.5);
  s.p90 = pct(0.9);
  double sum = 0, sq = 0;
  for (double x : v) sum += x;
  s.mean = sum / v.size();
  for (double x : v) sq += (x - s.mean) * (x - s.mean);
  s.stddev = v.size() > 1 ? std::sqrt(sq / (v.size() - 1)) : 0;
  return s;
}

CaptureStats MeasureCapture(const std::string& name,
                            const std::string& dir,
                            const calib::ImagePairOptions& pair_options,
                            const calib::TargetDefinition& target,
                            const CaptureStatsOptions& options) {
  const calib::DetectorOptions& detector = options.detector;
  CaptureStats out;
  out.name = name;
  const calib::ImagePairList list = calib::ListImagePairs(dir, pair_options);
  std::vector<calib::CornerObservation> obs;
  std::vector<double> noise_w, noise_b, edge, white, black, block, sat;
  std::vector<std::vector<calib::ChessboardImageStats::ShadingSample>> shading;
  std::vector<double> area;
  std::map<int, int> qualities;
  int width = 0, height = 0;
  for (size_t k = 0; k < list.pairs.size(); ++k) {
    const calib::ImagePair& p = list.pairs[k];
    cv::Mat img[2];
    try {
      calib::LoadImagePair(p, pair_options, &img[0], &img[1]);
    } catch (const std::exception& e) {
      out.problems.push_back(std::string("pair ") + p.key + ": " + e.what());
      out.num_images += 2;
      continue;
    }
    const std::string paths[2] = {p.left_path, p.right_path};
    for (int e = 0; e < 2; ++e) {
      ++out.num_images;
      width = img[e].cols;
      height = img[e].rows;
      const int q = calib::JpegQualityEstimate(ReadBytes(paths[e]));
      if (q > 0) ++qualities[q];
      block.push_back(calib::JpegBlockiness(img[e]));
      const calib::TargetDetection d = calib::DetectTarget(img[e], target, detector);
      if (!d.found) continue;
      ++out.num_found;
      const auto o = calib::DetectionToObservations(d, target, int(k), e);
      obs.insert(obs.end(), o.begin(), o.end());
      const calib::ChessboardImageStats s = calib::MeasureChessboardImage(img[e], d, target);
      if (!s.ok) {
        out.problems.push_back(paths[e] + ": " + s.message);
        continue;
      }
      noise_w.push_back(s.noise_white);
      noise_b.push_back(s.noise_black);
      edge.push_back(s.edge_sigma_px);
      white.push_back(s.white_level);
      black.push_back(s.black_level);
      sat.push_back(s.saturated_fraction);
      area.push_back(s.board_area_fraction);
      shading.push_back(s.shading);
    }
  }
  out.noise_white = SpreadOf(noise_w);
  out.noise_black = SpreadOf(noise_b);
  out.edge_sigma_px = SpreadOf(edge);
  out.white_level = SpreadOf(white);
  out.black_level = SpreadOf(black);
  out.blockiness = SpreadOf(block);
  out.board_area = SpreadOf(area);
  out.saturated_fraction = SpreadOf(sat).mean;
  out.lens_shading = FitShading(shading, false);
  out.lens_shading_curvature = FitShading(shading, true);
  int best = 0;
  for (const auto& [q, n] : qualities)
    if (n > best) best = n, out.jpeg_quality = q;

  // Fits: per-eye intrinsics (view RMS, poses) and the stereo fit (eye agreement).
  std::vector<calib::View> views[2];
  for (const auto& v : calib::GroupIntoViews(obs)) views[v.eye == 0 ? 0 : 1].push_back(v);
  if (views[0].empty() || views[1].empty()) {
    out.problems.push_back("no board seen by " + std::string(views[0].empty() ? "the left" : "the right") + " eye");
    return out;
  }
  StereoFitOptions so;
  so.width = width;
  so.height = height;
  const StereoFit fit = FitStereo(views[0], views[1], so);
  std::vector<double> view_rms, tilt, dist;
  const Eigen::Vector3d centre((target.cols - 1) * target.square_m / 2, (target.rows - 1) * target.square_m / 2, 0);
  for (int e = 0; e < 2; ++e) {
    const IntrinsicsFit& f = fit.per_eye[e];
    if (!f.ok) continue;
    out.mono_rms_px[e] = f.rms_px;
    view_rms.insert(view_rms.end(), f.view_rms_px.begin(), f.view_rms_px.end());
    for (const auto& pose : f.cam_from_target) {
      const Eigen::Vector3d n = pose.rotation * Eigen::Vector3d::UnitZ();
      tilt.push_back(std::acos(std::clamp(std::abs(n.z()), 0.0, 1.0)) * 180 / M_PI);
      dist.push_back((pose * centre).norm());
    }
  }
  out.view_rms_px = SpreadOf(view_rms);
  if (options.measure_warp) {
    for (int e = 0; e < 2; ++e) {
      double rms = 0;
      const Eigen::Vector2d w = FitBoardWarp(views[e], target, width, height, &rms);
      out.warp_mm[0] += 500 * w.x();
      out.warp_mm[1] += 500 * w.y();
      out.warped_rms_px += rms / 2;
    }
  }
  out.tilt_deg = SpreadOf(tilt);
  out.distance_m = SpreadOf(dist);
  if (!fit.ok) {
    out.problems.push_back("stereo fit: " + fit.message);
    return out;
  }
  out.num_pairs_used = int(fit.paired_frames.size());
  for (int e = 0; e < 2; ++e) out.stereo_rms_px[e] = fit.rms_px[e];
  out.stereo_rms_joint_px = fit.rms_joint_px;
  out.stereo_over_mono_rms = 0.5 * (fit.rms_px[0] / out.mono_rms_px[0] + fit.rms_px[1] / out.mono_rms_px[1]);
  // Eye agreement: each eye's board pose by PnP with the stereo fit's own intrinsics, the right
  // one carried into the left camera; what is left after removing the mean difference (the fit's
  // R, T minimise it) is the pair-to-pair jitter.
  std::map<int, const calib::View*> view_of[2];
  for (int e = 0; e < 2; ++e)
    for (const auto& v : views[e]) view_of[e][v.frame_index] = &v;
  std::vector<Eigen::Vector3d> dts, dths;
  const models::Rigid3d left_from_right = fit.right_from_left.Inverse();
  for (int f : fit.paired_frames) {
    models::Rigid3d pose[2];
    bool ok = true;
    for (int e = 0; e < 2 && ok; ++e) {
      const auto p = PosePnP(*view_of[e].at(f), fit.cameras[e]);
      ok = p.has_value();
      if (ok) pose[e] = *p;
    }
    if (!ok) continue;
    const models::Rigid3d l = pose[0], r = left_from_right * pose[1];
    dts.push_back(r * centre - l * centre);
    const Eigen::AngleAxisd aa(r.rotation * l.rotation.inverse());
    dths.push_back(aa.angle() * aa.axis());
  }
  Eigen::Vector3d mt = Eigen::Vector3d::Zero(), mr = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < dts.size(); ++i) mt += dts[i] / dts.size(), mr += dths[i] / dths.size();
  std::vector<double> jmm, jdeg;
  for (size_t i = 0; i < dts.size(); ++i) {
    jmm.push_back(1000 * (dts[i] - mt).norm());
    jdeg.push_back((dths[i] - mr).norm() * 180 / M_PI);
  }
  out.jitter_mm = SpreadOf(jmm);
  out.jitter_deg = SpreadOf(jdeg);
  return out;
}

}  // namespace owlcal::fitting
