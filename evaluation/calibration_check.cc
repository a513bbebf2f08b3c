#include "evaluation/calibration_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>

#include <opencv2/calib3d.hpp>

#include "fitting/calibration_check_problem.h"
#include "fitting/format.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace internal::check {
using namespace fitting::internal::check;  // the Ceres problem of the check (fitting/calibration_check_problem.h)
namespace {

// Rectified y_left - y_right of every corner seen in both views, per pair (mean) and all.
std::vector<double> EpipolarDy(const fitting::StereoRig& rig,
                               const std::vector<Pair>& pairs,
                               std::vector<double>* view_mean) {
  const fitting::Rectification rect = fitting::RectifyRig(rig);
  std::vector<double> dy;
  if (view_mean) view_mean->clear();
  for (const Pair& p : pairs) {
    std::map<int, cv::Point2d> right;
    for (size_t k = 0; k < p.view[1].pixels.size(); ++k)
      right[p.view[1].corner_ids[k]] = cv::Point2d(p.view[1].pixels[k].x(), p.view[1].pixels[k].y());
    std::vector<cv::Point2d> l, r;
    for (size_t k = 0; k < p.view[0].pixels.size(); ++k) {
      auto it = right.find(p.view[0].corner_ids[k]);
      if (it == right.end()) continue;
      l.emplace_back(p.view[0].pixels[k].x(), p.view[0].pixels[k].y());
      r.push_back(it->second);
    }
    double sum = 0;
    if (!l.empty()) {
      std::vector<cv::Point2d> lu, ru;
      cv::undistortPoints(
          l, lu, CameraMatrix(rig.cameras[0]), DistCoeffs(rig.cameras[0]), cv::Mat(rect.R1), cv::Mat(rect.P1));
      cv::undistortPoints(
          r, ru, CameraMatrix(rig.cameras[1]), DistCoeffs(rig.cameras[1]), cv::Mat(rect.R2), cv::Mat(rect.P2));
      for (size_t k = 0; k < lu.size(); ++k) dy.push_back(lu[k].y - ru[k].y), sum += lu[k].y - ru[k].y;
    }
    if (view_mean) view_mean->push_back(l.empty() ? 0.0 : sum / double(l.size()));
  }
  return dy;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0 : std::sqrt(s / double(v.size()));
}

// Names and display scale of the covariance layout [left params, right params, rv, T].
struct Layout {
  std::vector<std::string> names, units;
  std::vector<double> scale;  // display value = scale * parameter
};
Layout MakeLayout(const fitting::StereoRig& rig) {
  Layout l;
  const char* base[4] = {"fx", "fy", "cx", "cy"};
  for (int e = 0; e < 2; ++e) {
    const std::string eye = e == 0 ? "left." : "right.";
    for (size_t k = 0; k < rig.cameras[e].params.size(); ++k) {
      l.names.push_back(eye + (k < 4 ? std::string(base[k]) : "d" + std::to_string(k - 4)));
      l.units.push_back(k < 4 ? "px" : "");
      l.scale.push_back(1);
    }
  }
  for (const char* n : {"stereo.rx_deg", "stereo.ry_deg", "stereo.rz_deg"})
    l.names.push_back(n), l.units.push_back("deg"), l.scale.push_back(kRadToDeg);
  for (const char* n : {"stereo.tx_mm", "stereo.ty_mm", "stereo.tz_mm"})
    l.names.push_back(n), l.units.push_back("mm"), l.scale.push_back(1000);
  return l;
}

std::vector<CheckedParameter> Compare(const fitting::StereoRig& rig,
                                      const std::vector<double>& calibrated,
                                      const std::vector<double>& refit,
                                      const Eigen::MatrixXd& cov_refit,
                                      const std::vector<int>& indices,
                                      double moved_sigma) {
  const Layout l = MakeLayout(rig);
  const int n = rig.NumParams();
  const bool has_cov = rig.covariance.rows() == n && rig.covariance.cols() == n;
  std::vector<CheckedParameter> out;
  for (int i : indices) {
    CheckedParameter p;
    p.name = l.names[i];
    p.unit = l.units[i];
    p.calibrated = l.scale[i] * calibrated[i];
    p.refit = l.scale[i] * refit[i];
    p.sigma_calibration = has_cov ? l.scale[i] * std::sqrt(std::max(0.0, rig.covariance(i, i))) : 0.0;
    p.sigma_refit = l.scale[i] * std::sqrt(std::max(0.0, cov_refit(i, i)));
    const double s = std::hypot(p.sigma_calibration, p.sigma_refit);
    p.z = s > 0 ? (p.refit - p.calibrated) / s : 0.0;
    p.moved = std::abs(p.z) > moved_sigma;
    out.push_back(p);
  }
  return out;
}

// The parameters refits A and B free, as indices into [left params, right params, rv, T].
struct FreeSets {
  int n = 0, n0 = 0, n1 = 0;    // all parameters; the left and the right camera's
  std::vector<int> extrinsics;  // A: rv, T
  std::vector<int> all;         // B: fx fy cx cy of each camera, rv, T
  FreeMask Mask(const std::vector<int>& idx) const {
    FreeMask m(n, false);
    for (int i : idx) m[i] = true;
    return m;
  }
};

FreeSets MakeFreeSets(const fitting::StereoRig& rig) {
  FreeSets s;
  s.n = rig.NumParams();
  s.n0 = int(rig.cameras[0].params.size());
  s.n1 = int(rig.cameras[1].params.size());
  for (int i = 0; i < 6; ++i) s.extrinsics.push_back(s.n0 + s.n1 + i);
  for (int k = 0; k < 4; ++k) s.all.push_back(k);
  for (int k = 0; k < 4; ++k) s.all.push_back(s.n0 + k);
  s.all.insert(s.all.end(), s.extrinsics.begin(), s.extrinsics.end());
  return s;
}

// The parameters of blocks in the layout [left params, right params, rv, T].
std::vector<double> Flat(const Blocks& x) {
  std::vector<double> v = x.camera[0];
  v.insert(v.end(), x.camera[1].begin(), x.camera[1].end());
  v.insert(v.end(), x.right_from_left, x.right_from_left + 6);
  return v;
}

// The left and right views of each frame, both with at least 6 corners; the frames without
// such a pair go to c->unpaired_frames.
std::vector<Pair> PairViews(const std::vector<calib::CornerObservation>& observations, CalibrationCheck* c) {
  std::map<int, Pair> by_frame;
  for (const calib::View& v : calib::GroupIntoViews(observations)) {
    if (v.eye != 0 && v.eye != 1) continue;
    by_frame[v.frame_index].frame_index = v.frame_index;
    by_frame[v.frame_index].view[v.eye] = v;
  }
  std::vector<Pair> pairs;
  for (auto& [f, p] : by_frame) {
    if (p.view[0].pixels.size() >= 6 && p.view[1].pixels.size() >= 6)
      pairs.push_back(p);
    else
      c->unpaired_frames.push_back(f);
  }
  return pairs;
}

// Initial board poses from the left views into fixed->poses; per-eye RMS with each eye's own
// pose. False (c->message says why) when a view gives no pose.
bool InitialPoses(const fitting::StereoRig& rig, const std::vector<Pair>& pairs, Blocks* fixed, CalibrationCheck* c) {
  double mono_sq[2] = {0, 0};
  for (const Pair& p : pairs) {
    std::array<double, 6> pose[2];
    for (int e = 0; e < 2; ++e) {
      double rms = 0;
      if (!PoseOfView(rig.cameras[e], p.view[e], &pose[e], &rms)) {
        c->message =
            "frame " + std::to_string(p.frame_index) + ": no board pose for the " + (e ? "right" : "left") + " eye";
        return false;
      }
      mono_sq[e] += rms * rms * double(p.view[e].pixels.size());
      c->num_corners[e] += int(p.view[e].pixels.size());
    }
    fixed->poses.push_back(pose[0]);
  }
  for (int e = 0; e < 2; ++e) c->mono_rms_px[e] = std::sqrt(mono_sq[e] / c->num_corners[e]);
  return true;
}

// With the calibration held fixed (solve f): reprojection RMS per eye and joint with their
// sigmas, the rectified epipolar errors, and each view's.
void FixedStatistics(const fitting::StereoRig& rig,
                     const std::vector<Pair>& pairs,
                     const SolveOutcome& f,
                     CalibrationCheck* c) {
  for (int e = 0; e < 2; ++e) {
    c->rms_px[e] = f.rms_px[e];
    c->sigma_rms_px[e] = f.rms_px[e] / std::sqrt(2.0 * 2 * f.n[e]);  // 2 n residual components
  }
  c->rms_joint_px = f.rms_joint_px;
  c->sigma_rms_joint_px = f.rms_joint_px / std::sqrt(2.0 * 2 * (f.n[0] + f.n[1]));
  std::vector<double> view_dy;
  const std::vector<double> dy = EpipolarDy(rig, pairs, &view_dy);
  c->epipolar_num_corners = int(dy.size());
  double sum = 0;
  for (double v : dy) sum += v, c->epipolar_max_dy_px = std::max(c->epipolar_max_dy_px, std::abs(v));
  c->epipolar_mean_dy_px = dy.empty() ? 0 : sum / double(dy.size());
  c->epipolar_rms_dy_px = Rms(dy);
  double var = 0;
  for (double v : dy) var += (v - c->epipolar_mean_dy_px) * (v - c->epipolar_mean_dy_px);
  c->sigma_epipolar_mean_dy_px = dy.size() > 1 ? std::sqrt(var / double(dy.size() - 1) / double(dy.size())) : 0;
  for (size_t i = 0; i < pairs.size(); ++i) {
    CheckedView v;
    v.frame_index = pairs[i].frame_index;
    for (int e = 0; e < 2; ++e) v.num_corners[e] = int(pairs[i].view[e].pixels.size()), v.rms_px[e] = f.view_rms[i][e];
    v.mean_dy_px = view_dy[i];
    c->views.push_back(v);
  }
}

// Refits A and B on the new images, from the fixed solution's poses.
struct Refits {
  SolveOutcome a, b;
  std::vector<double> calibrated, refit_b;  // parameters in Flat's layout
  double corner_var_px2 = 0;                // corner noise from refit B, squared
};

// Refits A (extrinsics) and B (fx fy cx cy + extrinsics) and their comparison with the
// calibration into c; nullopt when either fails.
std::optional<Refits> Refit(const fitting::StereoRig& rig,
                            const std::vector<Pair>& pairs,
                            const Blocks& fixed,
                            const FreeSets& sets,
                            const CalibrationCheckOptions& options,
                            CalibrationCheck* c) {
  Refits r;
  Blocks a = fixed, b = fixed;
  r.a = Solve(pairs, sets.Mask(sets.extrinsics), true, options.max_iterations, &a);
  r.b = Solve(pairs, sets.Mask(sets.all), true, options.max_iterations, &b);
  if (!r.a.ok || !r.b.ok) return std::nullopt;
  c->refit_extrinsics_rms_px = r.a.rms_joint_px;
  c->refit_all_rms_px = r.b.rms_joint_px;
  const int num_res = 2 * (r.b.n[0] + r.b.n[1]);
  c->corner_sigma_px = std::sqrt((r.b.sum_sq[0] + r.b.sum_sq[1]) / std::max(1, num_res - r.b.num_free));
  r.corner_var_px2 = c->corner_sigma_px * c->corner_sigma_px;
  c->refit_all_epipolar_rms_dy_px = Rms(EpipolarDy(RigFromBlocks(rig, b), pairs, nullptr));
  r.calibrated = Flat(fixed);
  r.refit_b = Flat(b);
  c->extrinsics = Compare(rig, r.calibrated, Flat(a), r.a.cov * r.corner_var_px2, sets.extrinsics, options.moved_sigma);
  c->all = Compare(rig, r.calibrated, r.refit_b, r.b.cov * r.corner_var_px2, sets.all, options.moved_sigma);
  return r;
}

// What moved: each of refit B's parameters freed alone; the share of the excess cost
// (fixed - refit B) it removes, and its chi-square (cost drop / corner sigma^2, 1 dof).
void DiagnoseAlone(const fitting::StereoRig& rig,
                   const std::vector<Pair>& pairs,
                   const Blocks& fixed,
                   const SolveOutcome& f,
                   const Refits& refits,
                   const FreeSets& sets,
                   const CalibrationCheckOptions& options,
                   CalibrationCheck* c) {
  const SolveOutcome& rb = refits.b;
  const double cost_fixed = 0.5 * (f.sum_sq[0] + f.sum_sq[1]), cost_b = 0.5 * (rb.sum_sq[0] + rb.sum_sq[1]);
  const double excess = std::max(1e-12, cost_fixed - cost_b);
  const Layout layout = MakeLayout(rig);
  for (int i : sets.all) {
    Blocks one = fixed;
    const SolveOutcome r1 = Solve(pairs, sets.Mask({i}), false, options.max_iterations, &one);
    if (!r1.ok) continue;
    ParameterDiagnosis d;
    d.name = layout.names[i];
    d.unit = layout.units[i];
    d.change = layout.scale[i] * (Flat(one)[i] - refits.calibrated[i]);
    const double drop = cost_fixed - 0.5 * (r1.sum_sq[0] + r1.sum_sq[1]);
    d.explained = std::clamp(drop / excess, 0.0, 1.0);
    d.chi2 = 2 * drop / refits.corner_var_px2;
    d.significant = d.chi2 > options.single_chi2;
    c->single.push_back(d);
  }
  std::sort(c->single.begin(), c->single.end(), [](auto& x, auto& y) { return x.explained > y.explained; });
  for (const auto& d : c->single)
    if (d.significant && d.explained >= options.min_explained)
      c->moved.push_back(d.name + " " + (d.change >= 0 ? "+" : "") + fitting::FixedOrDash(d.change, 3) + " " + d.unit +
                         " alone explains " + fitting::FixedOrDash(100 * d.explained, 0) +
                         " % of the disagreement (chi2 " + fitting::FixedOrDash(d.chi2, 0) + ")");
}

// Ranging: a point refit B puts on the left axis at 1 m, triangulated by the calibration;
// its sigma from refit B's covariance (central differences over the free parameters).
void RangeAt1m(const fitting::StereoRig& rig,
               const Blocks& fixed,
               const Refits& refits,
               const FreeSets& sets,
               CalibrationCheck* c) {
  auto range_of = [&](const std::vector<double>& p) {
    Blocks x = fixed;
    x.camera[0].assign(p.begin(), p.begin() + sets.n0);
    x.camera[1].assign(p.begin() + sets.n0, p.begin() + sets.n0 + sets.n1);
    std::copy(p.begin() + sets.n0 + sets.n1, p.end(), x.right_from_left);
    const fitting::StereoRig r = RigFromBlocks(rig, x);
    const Eigen::Vector3d x_left(0, 0, 1.0), x_right = r.right_from_left * x_left;
    Eigen::Vector2d pl, pr;
    if (!r.cameras[0].Project(x_left.data(), pl.data()) || !r.cameras[1].Project(x_right.data(), pr.data()))
      return std::numeric_limits<double>::quiet_NaN();
    const auto z = TriangulateDepth(rig, fitting::RigParameters(rig), pl, pr, Eigen::Vector3d::UnitZ());
    return z ? *z : std::numeric_limits<double>::quiet_NaN();
  };
  const std::vector<double>& p_b = refits.refit_b;
  c->range_at_1m_m = range_of(p_b);
  const Eigen::MatrixXd cov_b = refits.b.cov * refits.corner_var_px2;
  Eigen::VectorXd J = Eigen::VectorXd::Zero(sets.n);
  for (int i : sets.all) {
    const double h = 1e-3 * std::max(1e-9, std::sqrt(std::max(0.0, cov_b(i, i))));
    std::vector<double> pp = p_b, pm = p_b;
    pp[i] += h;
    pm[i] -= h;
    J[i] = (range_of(pp) - range_of(pm)) / (2 * h);
  }
  c->sigma_range_at_1m_m = std::sqrt(std::max(0.0, J.dot(cov_b * J)));
}

// The verdict (calibration_check.h): the reasons to recalibrate, none: still valid.
void Verdict(const CalibrationCheckOptions& options, CalibrationCheck* c) {
  const double rms_limit = options.max_rms_ratio * c->refit_all_rms_px + options.min_rms_excess_px;
  if (c->rms_joint_px > rms_limit)
    c->reasons.push_back("reprojection RMS with the calibration fixed " + fitting::FixedOrDash(c->rms_joint_px, 3) +
                         " px > " + fitting::FixedOrDash(rms_limit, 3) + " px (" +
                         fitting::FixedOrDash(options.max_rms_ratio, 2) + " x the refit's " +
                         fitting::FixedOrDash(c->refit_all_rms_px, 3) + " + " +
                         fitting::FixedOrDash(options.min_rms_excess_px, 2) + ")");
  const double epi_limit = std::max(options.max_epipolar_rms_px, 2 * c->refit_all_epipolar_rms_dy_px);
  if (c->epipolar_rms_dy_px > epi_limit)
    c->reasons.push_back("rectified epipolar RMS " + fitting::FixedOrDash(c->epipolar_rms_dy_px, 3) + " px > " +
                         fitting::FixedOrDash(epi_limit, 3) + " px (mean dy " +
                         fitting::FixedOrDash(c->epipolar_mean_dy_px, 3) + " +- " +
                         fitting::FixedOrDash(c->sigma_epipolar_mean_dy_px, 3) + " px)");
  // Ranging: beyond the limit AND beyond 3 sigma of what the new images can tell.
  const double range_pct = 100 * (c->range_at_1m_m - 1.0), sigma_pct = 100 * c->sigma_range_at_1m_m;
  if (!std::isfinite(range_pct) ||
      (std::abs(range_pct) > options.max_range_error_pct && std::abs(range_pct) > 3 * sigma_pct))
    c->reasons.push_back("ranging: a point at 1 m by the new images is ranged at " +
                         fitting::FixedOrDash(c->range_at_1m_m, 4) + " m by the calibration (" +
                         fitting::FixedOrDash(range_pct, 2) + " % +- " + fitting::FixedOrDash(sigma_pct, 2) +
                         " %, limit " + fitting::FixedOrDash(options.max_range_error_pct, 1) + " % and 3 sigma)");
  c->verdict = c->reasons.empty() ? "still valid" : "recalibrate";
}

}  // namespace
}  // namespace internal::check

bool CalibrationCheckOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = "CalibrationCheckOptions." + m;
    return false;
  };
  if (min_pairs < 2) return fail("min_pairs must be >= 2");
  if (!(moved_sigma > 0)) return fail("moved_sigma must be > 0");
  if (!(max_rms_ratio >= 1)) return fail("max_rms_ratio must be >= 1");
  if (!(min_rms_excess_px >= 0)) return fail("min_rms_excess_px must be >= 0");
  if (!(max_epipolar_rms_px > 0)) return fail("max_epipolar_rms_px must be > 0");
  if (!(max_range_error_pct > 0)) return fail("max_range_error_pct must be > 0");
  if (!(single_chi2 > 0)) return fail("single_chi2 must be > 0");
  if (!(min_explained > 0 && min_explained <= 1)) return fail("min_explained must be in (0, 1]");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  return true;
}

CalibrationCheck CheckCalibration(const fitting::StereoRig& rig,
                                  const std::vector<calib::CornerObservation>& observations,
                                  const CalibrationCheckOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  using namespace internal::check;
  CalibrationCheck c;
  const int n = rig.NumParams();
  c.calibration_has_covariance = rig.covariance.rows() == n && rig.covariance.cols() == n;
  const std::vector<Pair> pairs = PairViews(observations, &c);
  c.num_pairs = int(pairs.size());
  if (c.num_pairs < options.min_pairs) {
    c.message = "only " + std::to_string(c.num_pairs) + " image pair(s) with the board in both eyes (needs " +
                std::to_string(options.min_pairs) + ")";
    return c;
  }
  Blocks fixed = BlocksFromRig(rig);
  if (!InitialPoses(rig, pairs, &fixed, &c)) return c;
  const FreeSets sets = MakeFreeSets(rig);
  const SolveOutcome f = Solve(pairs, sets.Mask({}), false, options.max_iterations, &fixed);
  if (!f.ok) {
    c.message = "the board-pose fit with the calibration fixed failed";
    return c;
  }
  FixedStatistics(rig, pairs, f, &c);
  const std::optional<Refits> refits = Refit(rig, pairs, fixed, sets, options, &c);
  if (!refits) {
    c.message = "a refit on the new images failed";
    return c;
  }
  DiagnoseAlone(rig, pairs, fixed, f, *refits, sets, options, &c);
  RangeAt1m(rig, fixed, *refits, sets, &c);
  Verdict(options, &c);
  c.ok = true;
  return c;
}

}  // namespace owlcal::evaluation
