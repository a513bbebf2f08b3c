#include "evaluation/ranging_eval.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <stdexcept>

#include "models/head_kinematics.h"
#include "models/statistics.h"
#include "models/units.h"
#include "models/vergence.h"

namespace owlcal::evaluation {
namespace {
// Fixations without a known target radius are size-checked against each other from this many on.
constexpr int kMinSizePeers = 3;

std::array<double, models::kNumServos> PwmToDouble(const models::PwmVector& p) {
  std::array<double, models::kNumServos> d;
  for (int i = 0; i < models::kNumServos; ++i) d[i] = p[i];
  return d;
}

std::array<int, models::kNumServos> Approach(const Fixation& f) {
  std::array<int, models::kNumServos> a;
  for (int i = 0; i < models::kNumServos; ++i) a[i] = f.approach[i];
  return a;
}

models::Rigid3d CamFromBase(const models::HeadModel& head, int eye, const models::JointAngles& a) {
  return head.geometry.cam_from_eye[eye] *
         models::HeadFromEye(head.geometry.centre_in_head[eye].data(), a.pan_rad[eye], a.tilt_rad[eye]).Inverse() *
         models::HeadFromBase(a.neck_rad);
}

// Range from continuous PWM values (for the quantisation Jacobian) and explicit pixels.
RangeFix RangeFromAngles(const models::HeadModel& head,
                         const models::JointAngles& a,
                         const std::optional<Eigen::Vector2d> px[2]) {
  RangeFix fix;
  Eigen::Vector3d origin[2], dir[2];
  for (int e = 0; e < 2; ++e) {
    const models::Rigid3d base_from_cam = CamFromBase(head, e, a).Inverse();
    Eigen::Vector3d ray(0, 0, 1);
    if (px[e]) {
      if (!head.intrinsics[e].Unproject(px[e]->data(), ray.data())) return fix;
    }
    origin[e] = base_from_cam.translation;
    dir[e] = base_from_cam.rotation * ray;
  }
  const auto r = models::ClosestPointOfRays(origin[0], dir[0], origin[1], dir[1]);
  if (!r || r->s1 <= 0 || r->s2 <= 0) return fix;
  const models::Rigid3d base_from_head = models::HeadFromBase(a.neck_rad).Inverse();
  const Eigen::Vector3d mid =
      base_from_head * (0.5 * (head.geometry.centre_in_head[0] + head.geometry.centre_in_head[1]));
  fix.ok = true;
  fix.point_in_base = r->point;
  fix.range_m = (r->point - mid).norm();
  fix.gap_m = r->gap;
  return fix;
}

RangeFix RangeFromPulses(const models::HeadModel& head,
                         const Fixation& f,
                         const std::array<double, models::kNumServos>& pulses,
                         const RangingOptions& options,
                         const Eigen::Vector2d* pixels) {
  const models::JointAngles a = head.Angles(pulses, Approach(f));
  std::optional<Eigen::Vector2d> px[2];
  if (options.use_image_offset) {
    for (int e = 0; e < 2; ++e) {
      if (pixels)
        px[e] = pixels[e];
      else
        px[e] = f.target_px[e];
    }
  }
  return RangeFromAngles(head, a, px);
}

// The size check (ranging_eval.h): mean over the eyes that measured the target's apparent
// radius of (f_x r / r_px) / (the fix's depth in that camera), r = radius_m; nullopt when not
// measured.
std::optional<double> SizeRatio(const models::HeadModel& head,
                                const Fixation& f,
                                const RangeFix& fix,
                                double radius_m) {
  if (!(radius_m > 0)) return std::nullopt;
  const models::JointAngles a = head.Angles(PwmToDouble(f.Pulses()), Approach(f));
  double sum = 0;
  int n = 0;
  for (int e = 0; e < 2; ++e) {
    if (!f.radius_px[e] || !(*f.radius_px[e] > 0)) continue;
    const double depth = head.PointInCam(models::Eye(e), a, fix.point_in_base).z();
    if (!(depth > 0)) continue;
    sum += head.intrinsics[e].params[0] * radius_m / *f.radius_px[e] / depth;
    ++n;
  }
  if (n == 0) return std::nullopt;
  return sum / n;
}

// The radius [m] a fixation's apparent size implies at its vergence fix: the harmonic mean over
// the eyes that measured it of r_px depth / f_x (SizeRatio = radius_m / this); nullopt when none did.
std::optional<double> ImpliedRadius(const models::HeadModel& head, const Fixation& f, const RangeFix& fix) {
  const auto inverse = SizeRatio(head, f, fix, 1.0);  // mean of f_x / (r_px depth)
  if (!inverse || !(*inverse > 0)) return std::nullopt;
  return 1.0 / *inverse;
}

double RangingStepFor(const std::string& name) {
  if (name.find("deg_per_us") != std::string::npos) return 1e-4;
  if (name.find("_deg") != std::string::npos) return 1e-2;
  return 0.1;  // us, mm, px
}

}  // namespace

bool RangingOptions::Check(std::string* why) const {
  if (!(max_size_ratio > 1)) {
    if (why) *why = "ranging options: max_size_ratio = " + std::to_string(max_size_ratio) + " must be > 1";
    return false;
  }
  if (!(pixel_sigma_px >= 0) || !(pwm_sigma_us >= 0) || !(max_ray_gap_m > 0) || !(max_ray_gap_per_m >= 0)) {
    if (why)
      *why = "RangingOptions: pixel_sigma_px = " + std::to_string(pixel_sigma_px) +
             ", pwm_sigma_us = " + std::to_string(pwm_sigma_us) +
             " and max_ray_gap_per_m = " + std::to_string(max_ray_gap_per_m) +
             " must be >= 0, max_ray_gap_m = " + std::to_string(max_ray_gap_m) + " > 0";
    return false;
  }
  return true;
}

std::vector<std::string> RangingParameterNames() {
  std::vector<std::string> n;
  for (const char* s : {"Lx", "Rx", "Ly", "Ry", "Neck"})
    for (const char* f : {"centre_us", "deg_per_us", "quad_deg", "cubic_deg", "hysteresis_us"})
      n.push_back(std::string("servo.") + s + "." + f);
  n.push_back("head.ipd_mm");
  for (const char* e : {"left", "right"})
    for (const char* f : {"fx", "fy", "cx", "cy"}) n.push_back(std::string(e) + "." + f);
  return n;
}

RangeFix RangeFromFixation(const models::HeadModel& head,
                           const Fixation& f,
                           const RangingOptions& options,
                           const Eigen::Vector2d* pixels) {
  return RangeFromPulses(head, f, PwmToDouble(f.Pulses()), options, pixels);
}

std::optional<double> NominalRange(const models::RobotConfig& config, const models::PwmVector& pwm_us) {
  const double k = models::ServoMap::kNominalDegPerUs * kDeg;
  const double tl = (pwm_us[models::kLx] - config.servos[models::kLx].centre_us) * k;
  const double tr = -(pwm_us[models::kRx] - config.servos[models::kRx].centre_us) * k;
  if (std::sin(tl + tr) <= 1e-9) return std::nullopt;
  const models::PlanarFix fix = models::SineRuleFix(0.065, tl, tr);
  if (!(fix.depth > 0)) return std::nullopt;
  return fix.range;
}

std::optional<Fixation> SyntheticFixation(const models::HeadModel& head,
                                          const Eigen::Vector3d& target_in_base,
                                          double neck_us) {
  Fixation f;
  std::array<double, models::kNumServos> pwm{};
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = head.servo_params[i][0];
  pwm[models::kNeck] = neck_us;
  models::JointAngles a = head.Angles(pwm);
  for (int e = 0; e < 2; ++e) {
    const double cx = head.intrinsics[e].params[2], cy = head.intrinsics[e].params[3];
    // Newton on (pan, tilt) so that the target projects to the principal point.
    for (int it = 0; it < 30; ++it) {
      Eigen::Vector2d p0;
      if (!head.Project(models::Eye(e), a, target_in_base, &p0)) return std::nullopt;
      const Eigen::Vector2d r = p0 - Eigen::Vector2d(cx, cy);
      if (r.norm() < 1e-9) break;
      Eigen::Matrix2d J;
      for (int k = 0; k < 2; ++k) {
        models::JointAngles b = a;
        (k == 0 ? b.pan_rad[e] : b.tilt_rad[e]) += 1e-6;
        Eigen::Vector2d p1;
        if (!head.Project(models::Eye(e), b, target_in_base, &p1)) return std::nullopt;
        J.col(k) = (p1 - p0) / 1e-6;
      }
      const Eigen::Vector2d step = J.colPivHouseholderQr().solve(r);
      a.pan_rad[e] -= step[0];
      a.tilt_rad[e] -= step[1];
    }
    const double u_pan = head.ServoPulse(models::kPanServo[e], a.pan_rad[e]);
    const double u_tilt = head.ServoPulse(models::kTiltServo[e], a.tilt_rad[e]);
    if (!std::isfinite(u_pan) || !std::isfinite(u_tilt)) return std::nullopt;
    f.pwm_us[models::kPanServo[e]] = int(std::lround(u_pan));
    f.pwm_us[models::kTiltServo[e]] = int(std::lround(u_tilt));
  }
  f.pwm_us[models::kNeck] = int(std::lround(neck_us));
  const models::JointAngles q = head.Angles(PwmToDouble(f.pwm_us));
  for (int e = 0; e < 2; ++e) {
    Eigen::Vector2d px;
    if (!head.Project(models::Eye(e), q, target_in_base, &px)) return std::nullopt;
    f.target_px[e] = px;
  }
  const models::Rigid3d base_from_head = models::HeadFromBase(q.neck_rad).Inverse();
  const Eigen::Vector3d mid =
      base_from_head * (0.5 * (head.geometry.centre_in_head[0] + head.geometry.centre_in_head[1]));
  f.true_distance_m = (target_in_base - mid).norm();
  return f;
}

namespace {

// Predicted variance of the range of one fixation.
double RangeVariance(const models::HeadModel& head,
                     const fitting::NamedCovariance& cov,
                     const Fixation& f,
                     const RangingOptions& options) {
  double var = 0;
  const int n = int(cov.names.size());
  if (n > 0) {
    Eigen::RowVectorXd J = Eigen::RowVectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const double h = RangingStepFor(cov.names[i]);
      models::HeadModel hp = head, hm = head;
      if (!fitting::PerturbHead(cov.names[i], h, &hp) || !fitting::PerturbHead(cov.names[i], -h, &hm)) continue;
      const RangeFix a = RangeFromFixation(hp, f, options), b = RangeFromFixation(hm, f, options);
      if (a.ok && b.ok) J[i] = (a.range_m - b.range_m) / (2 * h);
    }
    var += (J * cov.matrix * J.transpose())(0, 0);
  }
  const bool pixels = options.use_image_offset && f.target_px[0] && f.target_px[1];
  if (pixels) {
    const double h = 0.05;
    for (int e = 0; e < 2; ++e) {
      for (int k = 0; k < 2; ++k) {
        Eigen::Vector2d pp[2] = {*f.target_px[0], *f.target_px[1]}, pm[2] = {*f.target_px[0], *f.target_px[1]};
        pp[e][k] += h;
        pm[e][k] -= h;
        const RangeFix a = RangeFromFixation(head, f, options, pp), b = RangeFromFixation(head, f, options, pm);
        if (a.ok && b.ok) var += std::pow((a.range_m - b.range_m) / (2 * h) * options.pixel_sigma_px, 2);
      }
    }
  } else {
    // The gaze is the optical axis at the commanded PWM: the command's quantisation counts.
    const std::array<double, models::kNumServos> base = PwmToDouble(f.Pulses());
    const std::optional<Eigen::Vector2d> none[2];
    for (int servo : {int(models::kLx), int(models::kRx)}) {
      auto up = base, dn = base;
      up[servo] += 0.5;
      dn[servo] -= 0.5;
      const RangeFix a = RangeFromAngles(head, head.Angles(up, Approach(f)), none);
      const RangeFix b = RangeFromAngles(head, head.Angles(dn, Approach(f)), none);
      if (a.ok && b.ok) var += std::pow((a.range_m - b.range_m) * options.pwm_sigma_us, 2);
    }
  }
  // The pulse each servo applied, when it is not known exactly (dead band, PWM step).
  const std::array<double, models::kNumServos> pulses = PwmToDouble(f.Pulses());
  for (int servo = 0; servo < models::kNumServos; ++servo) {
    const double sigma = f.applied_sigma_us[servo];
    if (!(sigma > 0)) continue;
    auto up = pulses, dn = pulses;
    up[servo] += 0.5;
    dn[servo] -= 0.5;
    const RangeFix a = RangeFromPulses(head, f, up, options, nullptr);
    const RangeFix b = RangeFromPulses(head, f, dn, options, nullptr);
    if (a.ok && b.ok) var += std::pow((a.range_m - b.range_m) * sigma, 2);
  }
  return var;
}

// Each ok fixation's range fix; and the size check's radius for fixations without a known one: the
// median of the radii their apparent sizes imply at their own vergence fixes (all of one target),
// when at least kMinSizePeers measured a size (a fixation locked onto something else implies
// another radius). What was (not) checked goes to ev->notes.
std::optional<double> FixAndSharedRadius(const models::HeadModel& head,
                                         const std::vector<Fixation>& fixations,
                                         const RangingOptions& options,
                                         std::vector<RangeFix>* fixes_out,
                                         RangingEvaluation* out) {
  RangingEvaluation& ev = *out;
  std::vector<RangeFix>& fixes = *fixes_out;
  fixes.assign(fixations.size(), RangeFix());
  std::vector<double> implied;
  std::vector<int> unknown_size;  // ok fixations that measured a size but know no radius
  for (size_t i = 0; i < fixations.size(); ++i) {
    const Fixation& f = fixations[i];
    if (f.status != calib::TrialStatus::kOk) continue;
    fixes[i] = RangeFromFixation(head, f, options);
    if (f.target_radius_m || !fixes[i].ok) continue;
    if (const auto r = ImpliedRadius(head, f, fixes[i])) {
      implied.push_back(*r);
      unknown_size.push_back(f.index);
    }
  }
  std::optional<double> shared_radius;
  if (int(implied.size()) >= kMinSizePeers) {
    const double med = models::Median(implied);
    shared_radius = med;
    char b[256];
    std::snprintf(b,
                  sizeof b,
                  "size check: the target's radius is not given; the %zu fixations that measured its apparent "
                  "size are checked against their median, %.1f mm",
                  implied.size(),
                  1000 * med);
    ev.notes.push_back(b);
  } else if (!unknown_size.empty()) {
    std::string ids;
    for (int id : unknown_size) ids += (ids.empty() ? "" : ", ") + std::to_string(id);
    ev.notes.push_back("size check: not made on fixation" + std::string(unknown_size.size() > 1 ? "s " : " ") + ids +
                       ": the target's radius is not given and fewer than " + std::to_string(kMinSizePeers) +
                       " fixations measured its size to compare (a lock onto the background is not caught)");
  }
  return shared_radius;
}

// Theory: symmetric straight-ahead fixation at each distance, with the nominal method's errors
// for a small pulse-width and pixel error and the calibrated head's sigma.
void AddRangingTheory(const models::HeadModel& head,
                      const fitting::NamedCovariance& cov,
                      const RangingOptions& options,
                      const std::vector<double>& theory_distances_m,
                      RangingEvaluation* out) {
  RangingEvaluation& ev = *out;
  const double ipd = 0.065, k = models::ServoMap::kNominalDegPerUs * kDeg;
  const double f_px = 0.5 * (head.intrinsics[0].params[0] + head.intrinsics[1].params[0]);
  for (double D : theory_distances_m) {
    RangingTheoryRow t;
    t.distance_m = D;
    const double theta = std::atan(0.5 * ipd / D);
    // The larger of +1 us and -1 us on one eye (the error is asymmetric at long range).
    const double z_in = models::TangentDepth(ipd, theta + k, theta);
    const double z_out = models::TangentDepth(ipd, theta - k, theta);
    t.nominal_1us_rel = std::max(std::abs(z_in - D), std::abs(z_out - D)) / D;
    const double dth = 0.5 / f_px;
    const double z2_in = models::TangentDepth(ipd, theta + dth, theta + dth);
    const double z2_out = models::TangentDepth(ipd, theta - dth, theta - dth);
    t.nominal_half_px_rel = std::max(std::abs(z2_in - D), std::abs(z2_out - D)) / D;
    const double neck_us = head.servo_params[models::kNeck][0];
    const auto fx = SyntheticFixation(
        head,
        Eigen::Vector3d(0, 0, D + 0.5 * (head.geometry.centre_in_head[0].z() + head.geometry.centre_in_head[1].z())),
        neck_us);
    t.calibrated_sigma_rel = fx ? std::sqrt(RangeVariance(head, cov, *fx, options)) / fx->true_distance_m : kNaN;
    ev.theory.push_back(t);
  }
}

}  // namespace

RangingEvaluation EvaluateRanging(const models::HeadModel& head,
                                  const fitting::NamedCovariance& cov,
                                  const models::RobotConfig& config,
                                  const std::vector<Fixation>& fixations,
                                  const RangingOptions& options,
                                  const std::vector<double>& theory_distances_m) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  if (cov.matrix.rows() != int(cov.names.size()) || cov.matrix.cols() != int(cov.names.size()))
    throw std::invalid_argument("EvaluateRanging: covariance is " + std::to_string(cov.matrix.rows()) + "x" +
                                std::to_string(cov.matrix.cols()) + " for " + std::to_string(cov.names.size()) +
                                " names");
  RangingEvaluation ev;
  ev.propagated = cov.names;
  if (cov.names.empty()) ev.notes.push_back("no parameter covariance: sigma holds only the pixel/PWM noise");
  double sum2 = 0, sum_abs = 0, nom2 = 0;
  int within = 0, num_nom = 0;
  std::vector<RangeFix> fixes;
  const std::optional<double> shared_radius = FixAndSharedRadius(head, fixations, options, &fixes, &ev);
  for (size_t i = 0; i < fixations.size(); ++i) {
    const Fixation& f = fixations[i];
    RangingRow row;
    row.index = f.index;
    row.true_m = f.true_distance_m;
    row.status = f.status;
    row.reason = f.reason;
    row.range_m = row.error_m = row.rel_error = row.sigma_m = row.gap_m = row.size_ratio = kNaN;
    row.nominal_rel_error = kNaN;
    if (f.status != calib::TrialStatus::kOk) {
      ev.notes.push_back("fixation " + std::to_string(f.index) + " not ranged: " + calib::TrialStatusName(f.status) +
                         (f.reason.empty() ? "" : ": " + f.reason));
      ev.rows.push_back(row);
      continue;
    }
    row.nominal_m = NominalRange(config, f.pwm_us);
    row.nominal_rel_error = row.nominal_m ? (*row.nominal_m - row.true_m) / row.true_m : kNaN;
    if (row.nominal_m) {
      nom2 += row.nominal_rel_error * row.nominal_rel_error;
      ++num_nom;
    }
    const RangeFix& fix = fixes[i];
    const std::optional<double> radius = f.target_radius_m ? f.target_radius_m : shared_radius;
    if (!fix.ok) {
      row.status = calib::TrialStatus::kOffTarget;
      row.reason = "the gaze rays do not converge in front of the head";
    } else if (fix.gap_m > options.max_ray_gap_m + options.max_ray_gap_per_m * fix.range_m) {
      row.status = calib::TrialStatus::kOffTarget;
      row.gap_m = fix.gap_m;
      row.reason =
          "the two eyes' gaze rays pass " + std::to_string(1000 * fix.gap_m).substr(0, 6) + " mm apart (limit " +
          std::to_string(1000 * (options.max_ray_gap_m + options.max_ray_gap_per_m * fix.range_m)).substr(0, 5) +
          " mm): the eyes did not fixate one point";
    } else if (const auto ratio = radius ? SizeRatio(head, f, fix, *radius) : std::nullopt) {
      row.size_ratio = *ratio;
      if (!(*ratio <= options.max_size_ratio && *ratio >= 1 / options.max_size_ratio)) {
        row.status = calib::TrialStatus::kOffTarget;
        row.gap_m = fix.gap_m;
        char b[320];
        std::snprintf(b,
                      sizeof b,
                      "the target's apparent size puts it %.2f x the vergence distance (%.3f m; limit %.2f x%s): "
                      "the eyes fixated something else",
                      *ratio,
                      fix.range_m,
                      options.max_size_ratio,
                      f.target_radius_m ? "" : "; the radius the other fixations' sizes give");
        row.reason = b;
      }
    }
    if (row.status != calib::TrialStatus::kOk) {
      ev.notes.push_back("fixation " + std::to_string(f.index) + " not ranged: " + calib::TrialStatusName(row.status) +
                         ": " + row.reason);
      ev.rows.push_back(row);
      continue;
    }
    row.ok = true;
    row.range_m = fix.range_m;
    row.gap_m = fix.gap_m;
    row.error_m = fix.range_m - row.true_m;
    row.rel_error = row.error_m / row.true_m;
    row.sigma_m = std::sqrt(RangeVariance(head, cov, f, options));
    ++ev.num_ok;
    sum2 += row.rel_error * row.rel_error;
    sum_abs += std::abs(row.rel_error);
    ev.max_abs_rel_error = std::max(ev.max_abs_rel_error, std::abs(row.rel_error));
    if (std::abs(row.error_m) <= 2 * row.sigma_m) ++within;
    ev.rows.push_back(row);
  }
  if (ev.num_ok > 0) {
    ev.rms_rel_error = std::sqrt(sum2 / ev.num_ok);
    ev.mean_abs_rel_error = sum_abs / ev.num_ok;
    ev.fraction_within_2sigma = double(within) / ev.num_ok;
  }
  ev.nominal_rms_rel_error = num_nom > 0 ? std::sqrt(nom2 / num_nom) : kNaN;

  AddRangingTheory(head, cov, options, theory_distances_m, &ev);
  return ev;
}

}  // namespace owlcal::evaluation
