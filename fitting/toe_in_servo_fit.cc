#include "fitting/toe_in_servo_fit.h"

#include <cmath>
#include <sstream>

#include <Eigen/Dense>
#include <Eigen/Geometry>

#include "fitting/format.h"
#include "models/units.h"

namespace owlcal::fitting {
namespace {

struct ToeInLinearFit {
  Eigen::VectorXd x;
  Eigen::MatrixXd cov;  // unscaled (from the weights)
  double chi2 = 0;
  Eigen::VectorXd residual;
  bool ok = false;
};

ToeInLinearFit WeightedLeastSquares(const Eigen::MatrixXd& A, const Eigen::VectorXd& y, const Eigen::VectorXd& w) {
  ToeInLinearFit f;
  const Eigen::MatrixXd N = A.transpose() * w.asDiagonal() * A;
  const Eigen::FullPivLU<Eigen::MatrixXd> lu(N);
  if (lu.rank() < N.rows()) return f;
  f.cov = lu.inverse();
  f.x = f.cov * (A.transpose() * w.asDiagonal() * y);
  f.residual = y - A * f.x;
  f.chi2 = f.residual.cwiseProduct(f.residual).dot(w);
  f.ok = f.x.allFinite();
  return f;
}

}  // namespace

ToeInSet ToeInSetFromResult(const CalibrationResult& r, const std::string& name) {
  ToeInSet s;
  s.name = name;
  if (r.verdict.is_object() && r.verdict.contains("status")) s.verdict = r.verdict.at("status").get<std::string>();
  if (!r.stereo) {
    s.message = "no stereo calibration in the result";
    return s;
  }
  if (s.verdict == "unusable") {
    s.message = "the set's verdict is unusable";
    if (r.verdict.contains("reasons") && !r.verdict.at("reasons").empty())
      s.message += ": " + r.verdict.at("reasons").at(0).get<std::string>();
    return s;
  }
  const Eigen::Matrix3d R = r.stereo->right_from_left.rotation.toRotationMatrix();
  s.yaw_deg = std::atan2(R(0, 2), R(2, 2)) * kRadToDeg;
  const Eigen::AngleAxisd aa(r.stereo->right_from_left.rotation);
  const Eigen::Vector3d rv = aa.axis() * aa.angle() * kRadToDeg;
  s.pitch_deg = rv.x();
  s.roll_deg = rv.z();
  s.yaw_sigma_deg = std::sqrt(std::max(0.0, r.stereo->covariance(1, 1))) * kRadToDeg;
  if (!(s.yaw_sigma_deg > 0)) {
    s.message = "the stereo result has no rotation covariance";
    return s;
  }
  s.ok = true;
  return s;
}

bool ToeInFitOptions::Check(std::string* why) const {
  if (std::abs(rx_direction) != 1 || std::abs(lx_direction) != 1 || !(max_scale_sigma > 0)) {
    if (why) *why = "directions must be +1 or -1 and max_scale_sigma > 0";
    return false;
  }
  return true;
}

ToeInServoFit FitToeIn(const std::vector<ToeInSet>& sets, const ToeInFitOptions& o) {
  ToeInServoFit fit;
  std::string why;
  if (!o.Check(&why)) throw std::invalid_argument("ToeInFitOptions: " + why);
  std::vector<int> use;
  for (size_t i = 0; i < sets.size(); ++i) {
    if (sets[i].ok)
      use.push_back(static_cast<int>(i));
    else
      fit.notes.push_back(sets[i].name + " left out: " + sets[i].message);
  }
  fit.num_sets = static_cast<int>(use.size());
  if (use.size() < 3) {
    fit.message =
        std::to_string(use.size()) + " usable sets: at least 3 (at 3 or more different pan settings) are needed";
    return fit;
  }
  for (int i : use)
    if (sets[i].ry_us != sets[use[0]].ry_us || sets[i].ly_us != sets[use[0]].ly_us)
      fit.notes.push_back(sets[i].name + ": tilts (Ry " + FixedOrDash(sets[i].ry_us, 0) + ", Ly " +
                          FixedOrDash(sets[i].ly_us, 0) + ") differ from the first set's; keep the tilts fixed");
  const int n = static_cast<int>(use.size());
  double mean_rx = 0, mean_lx = 0;
  for (int i : use) mean_rx += sets[i].rx_us / n, mean_lx += sets[i].lx_us / n;
  Eigen::VectorXd y(n), w(n);
  Eigen::MatrixXd A3(n, 3), A2(n, 2);
  for (int k = 0; k < n; ++k) {
    const ToeInSet& s = sets[use[k]];
    const double l = o.lx_direction * (s.lx_us - mean_lx), r = -o.rx_direction * (s.rx_us - mean_rx);
    A3.row(k) << 1, r, l;
    A2.row(k) << 1, l + r;
    y[k] = s.yaw_deg;
    w[k] = 1 / (s.yaw_sigma_deg * s.yaw_sigma_deg);
  }
  auto scale_of = [](const ToeInLinearFit& f, int dof) {
    return dof > 0 ? std::max(1.0, std::sqrt(f.chi2 / dof)) : 1.0;
  };
  ToeInLinearFit per_eye, common = WeightedLeastSquares(A2, y, w);
  bool use_per_eye = false;
  if (o.scale_mode != ScaleMode::kCommon && n >= 4) {
    per_eye = WeightedLeastSquares(A3, y, w);
    if (per_eye.ok) {
      const double sc = scale_of(per_eye, n - 3);
      const double sr = std::sqrt(per_eye.cov(1, 1)) * sc, sl = std::sqrt(per_eye.cov(2, 2)) * sc;
      use_per_eye = o.scale_mode == ScaleMode::kPerEye || (sr < o.max_scale_sigma && sl < o.max_scale_sigma);
      if (!use_per_eye)
        fit.notes.push_back("one scale per eye is not determined by these sets (sigma " + FixedOrDash(sr, 4) + " / " +
                            FixedOrDash(sl, 4) +
                            " deg/us: Rx and Lx moved together); one common scale fitted. "
                            "To separate the eyes, add sets where only one eye moves");
    } else if (o.scale_mode == ScaleMode::kPerEye) {
      fit.message = "one scale per eye cannot be fitted: Rx and Lx always move together in these sets";
      return fit;
    } else {
      fit.notes.push_back(
          "Rx and Lx moved together in every set, so only their common scale is measured; to "
          "separate the eyes, add sets where only one eye moves");
    }
  } else if (o.scale_mode == ScaleMode::kPerEye) {
    fit.message = "one scale per eye needs at least 4 usable sets";
    return fit;
  }
  const ToeInLinearFit& f = use_per_eye ? per_eye : common;
  if (!f.ok) {
    fit.message =
        "the sets do not determine a scale: every set has the same (Lx - Rx); pan the eyes to at least "
        "3 different settings";
    return fit;
  }
  const int p = use_per_eye ? 3 : 2;
  fit.dof = n - p;
  if (fit.dof < 1) {
    fit.message = std::to_string(n) + " sets for " + std::to_string(p) +
                  " parameters: no redundancy, so nothing measures the scatter between sets; add sets";
    return fit;
  }
  fit.per_eye = use_per_eye;
  fit.chi2 = f.chi2;
  fit.chi2_per_dof = f.chi2 / fit.dof;
  const double scale = scale_of(f, fit.dof);
  fit.offset_deg = f.x[0];
  fit.offset_sigma = std::sqrt(f.cov(0, 0)) * scale;
  if (use_per_eye) {
    fit.rx_deg_per_us = f.x[1];
    fit.lx_deg_per_us = f.x[2];
    fit.rx_sigma = std::sqrt(f.cov(1, 1)) * scale;
    fit.lx_sigma = std::sqrt(f.cov(2, 2)) * scale;
  } else {
    fit.rx_deg_per_us = fit.lx_deg_per_us = f.x[1];
    fit.rx_sigma = fit.lx_sigma = std::sqrt(f.cov(1, 1)) * scale;
  }
  double ss = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    const ToeInSet& s = sets[use[k]];
    ToeInSetResidual r;
    r.set = use[k];
    r.residual_deg = f.residual[k];
    r.predicted_deg = y[k] - f.residual[k];
    r.z = r.residual_deg / s.yaw_sigma_deg;
    fit.residuals.push_back(r);
    ss += r.residual_deg * r.residual_deg;
    s2 += s.yaw_sigma_deg * s.yaw_sigma_deg;
  }
  // RMS residual with the degrees of freedom accounted for, and the part the calibrations'
  // own sigma does not explain.
  fit.rms_residual_deg = std::sqrt(ss / fit.dof);
  fit.repeatability_deg = std::sqrt(std::max(0.0, ss / fit.dof - s2 / n));
  if (fit.chi2_per_dof > 1)
    fit.notes.push_back("chi2/dof = " + FixedOrDash(fit.chi2_per_dof, 1) +
                        ": the sets scatter more than their calibration sigma (servo repeatability about " +
                        FixedOrDash(fit.repeatability_deg, 2) + " deg per set); sigmas scaled by sqrt(chi2/dof)");
  auto add = [&](const std::string& name, double v, double sigma, const std::string& unit, const std::string& note) {
    Parameter q;
    q.name = name;
    q.value = v;
    q.sigma = sigma;
    q.unit = unit;
    q.note = note;
    fit.parameters.push_back(q);
  };
  const std::string shared = use_per_eye ? "" : "one scale for both eyes";
  add("servo.Rx.deg_per_us", fit.rx_deg_per_us, fit.rx_sigma, "deg/us", shared);
  add("servo.Lx.deg_per_us", fit.lx_deg_per_us, fit.lx_sigma, "deg/us", shared);
  add("servo.Rx.us_per_deg",
      1 / fit.rx_deg_per_us,
      fit.rx_sigma / (fit.rx_deg_per_us * fit.rx_deg_per_us),
      "us/deg",
      shared);
  add("servo.Lx.us_per_deg",
      1 / fit.lx_deg_per_us,
      fit.lx_sigma / (fit.lx_deg_per_us * fit.lx_deg_per_us),
      "us/deg",
      shared);
  add("toe_in.yaw_at_mean_pwm_deg",
      fit.offset_deg,
      fit.offset_sigma,
      "deg",
      "relative yaw at Rx " + FixedOrDash(mean_rx, 1) + ", Lx " + FixedOrDash(mean_lx, 1) + " us");
  add("toe_in.repeatability_deg",
      fit.repeatability_deg,
      std::numeric_limits<double>::quiet_NaN(),
      "deg",
      "per-set scatter beyond the calibration sigma");
  fit.parameters.back().determined = fit.dof >= 2;
  fit.ok = true;
  return fit;
}

}  // namespace owlcal::fitting
