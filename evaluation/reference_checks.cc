#include "evaluation/reference_checks.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include <Eigen/Dense>

#include "fitting/intrinsics_fit.h"
#include "io/json_strict.h"
#include "models/slew_lag.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {

struct CheckSpread {
  int n = 0;
  double mean = NAN, sigma = NAN, median = NAN, min = NAN, max = NAN;
};

// Mean, sample standard deviation (n >= 2), median and range.
CheckSpread CheckSpreadOf(std::vector<double> v) {
  CheckSpread s;
  s.n = int(v.size());
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  double sum = 0;
  for (double x : v) sum += x;
  s.mean = sum / v.size();
  if (v.size() >= 2) {
    double ss = 0;
    for (double x : v) ss += (x - s.mean) * (x - s.mean);
    s.sigma = std::sqrt(ss / (v.size() - 1));
  }
  s.median = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  s.min = v.front();
  s.max = v.back();
  return s;
}

std::string Fixed(double v, int digits) {
  char b[64];
  std::snprintf(b, sizeof b, "%.*f", digits, v);
  return b;
}

int64_t FrameStartNs(int64_t seq, double fps) { return int64_t(std::llround(double(seq) * 1e9 / fps)); }

}  // namespace

std::optional<double> ExpectedLatencyReadingMs(const LatencyTruth& truth, const LatencyTrial& t, std::string* why) {
  auto fail = [&](const std::string& m) -> std::optional<double> {
    if (why) *why = m;
    return std::nullopt;
  };
  if (!t.command_ns || !t.from_us || !t.to_us || !t.threshold_px)
    return fail("latency.csv lacks command_ns, from_us, to_us or threshold_px (a dataset older than them)");
  if (t.servo < 0 || t.servo >= models::kNumServos) return fail("unknown servo");
  if (!(truth.fps > 0)) return fail("truth fps not positive");
  const int eye = t.servo == models::kLx || t.servo == models::kLy ? models::kLeftEye : models::kRightEye;
  const int axis = t.servo == models::kRy || t.servo == models::kLy ? 1 : 0;
  // The step's true angle (each end on its approach side) and image shift at the image centre.
  const int approach = *t.to_us > *t.from_us ? 1 : (*t.to_us < *t.from_us ? -1 : 0);
  const double a0 = truth.head.ServoAngle(t.servo, *t.from_us, -approach);
  const double a1 = truth.head.ServoAngle(t.servo, *t.to_us, approach);
  const double step_rad = std::abs(a1 - a0);
  const double shift_px = truth.head.intrinsics[eye].params[axis] * std::tan(step_rad);
  if (!(shift_px > *t.threshold_px))
    return fail("the true image shift (" + Fixed(shift_px, 2) + " px) never passes the threshold");
  // Fraction of the step the joint must cover, and when it does (slew + first-order lag from
  // rest, in units of the step; y rises monotonically).
  const double fraction = *t.threshold_px / shift_px;
  const double slew = truth.slew_deg_per_s[t.servo] / kRadToDeg / step_rad;
  const double lag = truth.lag_s[t.servo];
  auto y = [&](double s) { return models::SlewLagState(0, 0, 1, slew, lag, s); };
  double lo = 0, hi = 1.0 / slew + 50 * lag + 1e-3;
  for (int i = 0; i < 100; ++i) {
    const double mid = 0.5 * (lo + hi);
    (y(mid) > fraction ? hi : lo) = mid;
  }
  const int64_t motion_ns = *t.command_ns + int64_t(std::llround(hi * 1e9));
  // The first exposure of that eye (middle row) after it; its frame's receive stamp.
  const int64_t offset_ns = (eye == models::kRightEye ? int64_t(std::llround(truth.eye_offset_ms * 1e6)) : 0) +
                            int64_t(std::llround(truth.rolling_shutter_ms * 0.5e6));
  int64_t seq = std::max<int64_t>(0, int64_t(std::floor(double(motion_ns - offset_ns) * truth.fps / 1e9)) - 1);
  while (FrameStartNs(seq, truth.fps) + offset_ns <= motion_ns) ++seq;
  const int64_t stamp =
      FrameStartNs(seq, truth.fps) +
      int64_t(std::llround(std::max(truth.latency_ms * 1e6, 0.0) + std::max(0.0, truth.eye_offset_ms) * 1e6));
  return (stamp - *t.command_ns) * 1e-6;
}

LatencyCheck CheckLatency(const std::vector<LatencyTrial>& trials, const std::optional<LatencyTruth>& truth) {
  LatencyCheck c;
  if (truth) {
    c.stream_latency_truth_ms = truth->latency_ms;
    c.fps = truth->fps;
    if (truth->drop_probability > 0)
      c.notes.push_back("the virtual Owl drops frames (probability " + Fixed(truth->drop_probability, 3) +
                        "): a dropped frame delays a reading beyond the prediction");
  }
  std::vector<int> servos;
  for (const auto& t : trials)
    if (std::find(servos.begin(), servos.end(), t.servo) == servos.end()) servos.push_back(t.servo);
  std::map<std::string, int> why_no_truth;
  auto group = [&](const std::string& name, auto pick) {
    LatencyGroup g;
    g.servo = name;
    std::vector<double> ms, pred;
    double max_err = 0;
    for (const auto& t : trials) {
      if (!pick(t)) continue;
      ++g.num_trials;
      if (!t.latency_ms) continue;
      ms.push_back(*t.latency_ms);
      if (!truth) continue;
      std::string why;
      if (const auto p = ExpectedLatencyReadingMs(*truth, t, &why)) {
        pred.push_back(*p);
        max_err = std::max(max_err, std::abs(*t.latency_ms - *p));
        g.num_on_predicted_frame += std::abs(*t.latency_ms - *p) < 1.0;
      } else if (name != "all") {
        ++why_no_truth[why];
      }
    }
    const CheckSpread s = CheckSpreadOf(ms);
    g.num_ok = s.n;
    g.mean_ms = s.mean;
    g.sigma_ms = s.sigma;
    g.median_ms = s.median;
    g.min_ms = s.min;
    g.max_ms = s.max;
    g.num_with_truth = int(pred.size());
    if (!pred.empty()) {
      g.truth_mean_ms = CheckSpreadOf(pred).mean;
      g.max_abs_error_ms = max_err;
    }
    c.groups.push_back(g);
  };
  for (int s : servos)
    group(s >= 0 && s < models::kNumServos ? models::kServoNames[s] : "servo " + std::to_string(s),
          [s](const LatencyTrial& t) { return t.servo == s; });
  if (servos.size() > 1) group("all", [](const LatencyTrial&) { return true; });
  for (const auto& t : trials)
    if (!t.latency_ms)
      c.notes.push_back("trial " + std::to_string(t.trial) + " of step " + std::to_string(t.step_index) +
                        ": no image motion seen (not in the mean)");
  for (const auto& [why, n] : why_no_truth) c.notes.push_back(std::to_string(n) + " trial(s) without truth: " + why);
  return c;
}

AlignmentCheck CheckAlignment(const std::vector<AlignmentFrame>& frames,
                              int image_width,
                              double focal_px,
                              double deg_per_us) {
  AlignmentCheck c;
  c.num_frames = int(frames.size());
  c.tolerance_vertical_px = 1.0;
  c.tolerance_roll_deg = std::atan(1.0 / (0.5 * image_width)) * kRadToDeg;
  c.tolerance_source =
      "a block matcher searching along image rows (OpenCV StereoBM/SGBM, the course's disparity code on unrectified "
      "images) tolerates about 1 px of vertical disparity: |vertical offset| <= 1 px, and |roll| <= atan(1 px / " +
      std::to_string(image_width / 2) + " px), 1 px at the image's side edges";
  // The chessboard frames when there are any (the phase correlation has no roll and is coarser).
  bool any_board = false;
  for (const auto& f : frames) any_board |= f.method == "chessboard" && f.vertical_offset_px.has_value();
  std::vector<double> roll, dy, dx;
  for (const auto& f : frames) {
    if (any_board && f.method != "chessboard") continue;
    if (f.roll_deg) roll.push_back(*f.roll_deg);
    if (f.vertical_offset_px) dy.push_back(*f.vertical_offset_px);
    if (f.horizontal_offset_px) dx.push_back(*f.horizontal_offset_px);
    if (c.method.empty()) c.method = f.method;
  }
  const CheckSpread r = CheckSpreadOf(roll), v = CheckSpreadOf(dy), h = CheckSpreadOf(dx);
  c.num_roll = r.n;
  c.num_vertical = v.n;
  c.roll_deg = r.mean;
  c.roll_sigma_deg = r.sigma;
  c.vertical_px = v.mean;
  c.vertical_sigma_px = v.sigma;
  c.horizontal_px = h.mean;
  if (v.n == 0) {
    c.verdict = "not measured";
    c.advice.push_back(
        "no frame measured the vertical offset: place a chessboard in view of both eyes at the centre "
        "pose and run the alignment protocol again");
    return c;
  }
  const bool dy_ok = std::abs(c.vertical_px) <= c.tolerance_vertical_px;
  const bool roll_ok = r.n == 0 || std::abs(c.roll_deg) <= c.tolerance_roll_deg;
  c.verdict = dy_ok && roll_ok ? "within tolerance" : "outside tolerance";
  if (r.n == 0)
    c.advice.push_back("roll not measured (no chessboard in both eyes): the verdict is on the offset alone");
  if (!dy_ok) {
    const double us = std::abs(c.vertical_px) / focal_px * kRadToDeg / deg_per_us;
    c.advice.push_back("vertical offset " + Fixed(c.vertical_px, 2) + " px (left - right) is about " +
                       std::to_string(int(std::lround(us))) +
                       " us of one eye's tilt (Ry or Ly): adjust its centre in the robot file, or use the "
                       "calibration's rectification (calibration.yaml R1 R2 P1 P2), which removes it");
  }
  if (!roll_ok)
    c.advice.push_back("roll " + Fixed(c.roll_deg, 3) +
                       " deg between the eyes: no servo rolls a camera; turn one camera in its mount (the guide's Fig. "
                       "8a) or use the calibration's rectification");
  return c;
}

std::array<double, 2> EdgeFovDeg(const models::CameraIntrinsics& cam) {
  const double cx = cam.params[2], cy = cam.params[3];
  auto angle = [&](double u0, double v0, double u1, double v1) {
    Eigen::Vector3d a, b;
    const double p0[2] = {u0, v0}, p1[2] = {u1, v1};
    if (!cam.Unproject(p0, a.data()) || !cam.Unproject(p1, b.data())) return double(NAN);
    return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * kRadToDeg;
  };
  return {angle(-0.5, cy, cam.width - 0.5, cy), angle(cx, -0.5, cx, cam.height - 0.5)};
}

FovCheck CheckFieldOfView(const fitting::CalibrationResult& result,
                          const std::optional<std::array<models::CameraIntrinsics, 2>>& truth,
                          const PiCameraDatasheet& ds) {
  FovCheck c;
  c.source = ds.source;
  for (int e = 0; e < 2; ++e) {
    if (!result.cameras[e]) continue;
    const models::CameraIntrinsics& cam = *result.cameras[e];
    const std::string eye = models::kEyeNames[e];
    const std::vector<std::string> names = fitting::IntrinsicParamNames(cam.model);
    const int n = int(std::min(names.size(), cam.params.size()));
    // Covariance of this eye's intrinsics: the stereo fit's joint block, else the sigmas.
    Eigen::MatrixXd cov = Eigen::MatrixXd::Zero(n, n);
    bool joint = false;
    if (result.stereo && result.stereo->full_covariance.rows() == int(result.stereo->full_names.size())) {
      std::vector<int> idx;
      for (int k = 0; k < n; ++k) {
        const auto& fn = result.stereo->full_names;
        const auto it = std::find(fn.begin(), fn.end(), eye + "." + names[k]);
        idx.push_back(it == fn.end() ? -1 : int(it - fn.begin()));
      }
      joint = std::all_of(idx.begin(), idx.end(), [](int i) { return i >= 0; });
      if (joint)
        for (int a = 0; a < n; ++a)
          for (int b = 0; b < n; ++b) cov(a, b) = result.stereo->full_covariance(idx[a], idx[b]);
    }
    bool any_sigma = joint;
    if (!joint)
      for (int k = 0; k < n; ++k)
        if (const fitting::Parameter* p = result.Find(eye + "." + names[k]);
            p && p->determined && std::isfinite(p->sigma)) {
          cov(k, k) = p->sigma * p->sigma;
          any_sigma = true;
        }
    if (!any_sigma) cov.setConstant(NAN);  // no sigma known: none reported
    FovRow row;
    row.eye = eye;
    row.fx = cam.params[0];
    row.fy = cam.params[1];
    row.fx_sigma = std::sqrt(cov(0, 0));
    row.fy_sigma = std::sqrt(cov(1, 1));
    const std::array<double, 2> fov = EdgeFovDeg(cam);
    row.hfov_deg = fov[0];
    row.vfov_deg = fov[1];
    Eigen::MatrixXd J(2, n);
    for (int k = 0; k < n; ++k) {
      const double h = 1e-6 * std::max(1.0, std::abs(cam.params[k]));
      models::CameraIntrinsics p = cam, m = cam;
      p.params[k] += h;
      m.params[k] -= h;
      const auto fp = EdgeFovDeg(p), fm = EdgeFovDeg(m);
      J(0, k) = (fp[0] - fm[0]) / (2 * h);
      J(1, k) = (fp[1] - fm[1]) / (2 * h);
    }
    const Eigen::Matrix2d cf = J * cov * J.transpose();
    row.hfov_sigma_deg = any_sigma ? std::sqrt(std::max(0.0, cf(0, 0))) : NAN;
    row.vfov_sigma_deg = any_sigma ? std::sqrt(std::max(0.0, cf(1, 1))) : NAN;
    row.pinhole_hfov_deg = 2 * std::atan(0.5 * cam.width / cam.params[0]) * kRadToDeg;
    row.pinhole_vfov_deg = 2 * std::atan(0.5 * cam.height / cam.params[1]) * kRadToDeg;
    row.datasheet_f_px = ds.FocalPx(cam.width);
    row.datasheet_hfov_deg = ds.hfov_deg;
    row.datasheet_vfov_deg = ds.vfov_deg;
    if (truth) {
      const models::CameraIntrinsics& t = (*truth)[e];
      row.truth_fx = t.params[0];
      const auto tf = EdgeFovDeg(t);
      row.truth_hfov_deg = tf[0];
      row.truth_vfov_deg = tf[1];
    }
    c.rows.push_back(row);
    if (!joint)
      c.notes.push_back(eye + (any_sigma
                                   ? ": sigma from the per-parameter sigmas (no joint covariance of the intrinsics)"
                                   : ": no sigma (the result holds no covariance of these intrinsics)"));
  }
  c.notes.push_back("datasheet focal length at " + std::to_string(result.cameras[0] ? result.cameras[0]->width : 640) +
                    " px: 3.6 mm / (1.4 um x 2592 / width) = " +
                    Fixed(ds.FocalPx(result.cameras[0] ? result.cameras[0]->width : 640), 1) +
                    " px; real Owl calibrations measured 577.9-590.6 px (2017, 2024), 7-9 % below it");
  return c;
}

nlohmann::json ToJson(const LatencyCheck& c) {
  nlohmann::json groups = nlohmann::json::array();
  for (const auto& g : c.groups)
    groups.push_back(
        {{"servo", g.servo},
         {"num_trials", g.num_trials},
         {"num_ok", g.num_ok},
         {"mean_ms", io::JsonNumber(g.mean_ms)},
         {"sigma_ms", io::JsonNumber(g.sigma_ms)},
         {"median_ms", io::JsonNumber(g.median_ms)},
         {"min_ms", io::JsonNumber(g.min_ms)},
         {"max_ms", io::JsonNumber(g.max_ms)},
         {"truth_mean_ms", io::JsonNumber(g.truth_mean_ms)},
         {"error_ms", g.truth_mean_ms ? io::JsonNumber(g.mean_ms - *g.truth_mean_ms) : nlohmann::json(nullptr)},
         {"max_abs_trial_error_ms", io::JsonNumber(g.max_abs_error_ms)},
         {"num_with_truth", g.num_with_truth},
         {"num_on_predicted_frame", g.num_on_predicted_frame}});
  return {{"what",
           "command -> first received frame whose image moved by the threshold (latency protocol), mean and sample "
           "standard deviation over the trials; truth (virtual Owl): the reading its stream latency, frame timing "
           "and servo slew and lag predict for each trial"},
          {"groups", groups},
          {"stream_latency_truth_ms", io::JsonNumber(c.stream_latency_truth_ms)},
          {"fps", io::JsonNumber(c.fps)},
          {"notes", c.notes}};
}

nlohmann::json ToJson(const AlignmentCheck& c) {
  return {{"num_frames", c.num_frames},
          {"num_roll", c.num_roll},
          {"num_vertical", c.num_vertical},
          {"method", c.method},
          {"roll_deg", io::JsonNumber(c.roll_deg)},
          {"roll_sigma_deg", io::JsonNumber(c.roll_sigma_deg)},
          {"vertical_offset_px", io::JsonNumber(c.vertical_px)},
          {"vertical_offset_sigma_px", io::JsonNumber(c.vertical_sigma_px)},
          {"horizontal_offset_px", io::JsonNumber(c.horizontal_px)},
          {"tolerance_roll_deg", io::JsonNumber(c.tolerance_roll_deg)},
          {"tolerance_vertical_px", io::JsonNumber(c.tolerance_vertical_px)},
          {"tolerance_source", c.tolerance_source},
          {"verdict", c.verdict},
          {"advice", c.advice}};
}

nlohmann::json ToJson(const FovCheck& c) {
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : c.rows)
    rows.push_back({{"eye", r.eye},
                    {"fx_px", io::JsonNumber(r.fx)},
                    {"fx_sigma_px", io::JsonNumber(r.fx_sigma)},
                    {"fy_px", io::JsonNumber(r.fy)},
                    {"fy_sigma_px", io::JsonNumber(r.fy_sigma)},
                    {"hfov_deg", io::JsonNumber(r.hfov_deg)},
                    {"hfov_sigma_deg", io::JsonNumber(r.hfov_sigma_deg)},
                    {"vfov_deg", io::JsonNumber(r.vfov_deg)},
                    {"vfov_sigma_deg", io::JsonNumber(r.vfov_sigma_deg)},
                    {"pinhole_hfov_deg", io::JsonNumber(r.pinhole_hfov_deg)},
                    {"pinhole_vfov_deg", io::JsonNumber(r.pinhole_vfov_deg)},
                    {"datasheet_f_px", io::JsonNumber(r.datasheet_f_px)},
                    {"datasheet_hfov_deg", io::JsonNumber(r.datasheet_hfov_deg)},
                    {"datasheet_vfov_deg", io::JsonNumber(r.datasheet_vfov_deg)},
                    {"f_minus_datasheet_px", io::JsonNumber(r.fx - r.datasheet_f_px)},
                    {"hfov_minus_datasheet_deg", io::JsonNumber(r.hfov_deg - r.datasheet_hfov_deg)},
                    {"vfov_minus_datasheet_deg", io::JsonNumber(r.vfov_deg - r.datasheet_vfov_deg)},
                    {"truth_fx_px", io::JsonNumber(r.truth_fx)},
                    {"truth_hfov_deg", io::JsonNumber(r.truth_hfov_deg)},
                    {"truth_vfov_deg", io::JsonNumber(r.truth_vfov_deg)}});
  return {{"what",
           "field of view through the image's outer edges (lens model included) and focal length of each fitted "
           "camera, against the Pi camera datasheet"},
          {"source", c.source},
          {"rows", rows},
          {"notes", c.notes}};
}

}  // namespace owlcal::evaluation
