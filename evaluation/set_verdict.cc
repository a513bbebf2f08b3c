#include "evaluation/set_verdict.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "fitting/format.h"

#include <Eigen/Geometry>

namespace owlcal::evaluation {
namespace {

const char* kEye[2] = {"left", "right"};
const char* kZone[9] = {
    "top-left", "top", "top-right", "left edge", "centre", "right edge", "bottom-left", "bottom", "bottom-right"};

int ZoneOf(const Eigen::Vector2d& q, int width, int height) {
  const int zx = std::clamp(static_cast<int>(3 * (q.x() + 0.5) / width), 0, 2);
  const int zy = std::clamp(static_cast<int>(3 * (q.y() + 0.5) / height), 0, 2);
  return 3 * zy + zx;
}

// 90th percentile of the grid values within `r` of the half-diagonal from the image centre
// (a value that is not finite counts as larger than any other).
double P90Within(const std::vector<Eigen::Vector2d>& px, const std::vector<double>& v, int w, int h, double r) {
  const Eigen::Vector2d c((w - 1) / 2.0, (h - 1) / 2.0);
  std::vector<double> in;
  for (size_t i = 0; i < px.size() && i < v.size(); ++i)
    if ((px[i] - c).norm() <= r * c.norm()) in.push_back(std::isfinite(v[i]) ? v[i] : 1e300);
  if (in.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::sort(in.begin(), in.end());
  const double p = in[std::min(in.size() - 1, static_cast<size_t>(0.9 * in.size()))];
  return p >= 1e300 ? std::numeric_limits<double>::infinity() : p;
}

struct TrustedRegion {
  std::vector<bool> trusted;
  double fraction = 0, working_fraction = 0;
};

// Grid pixels with sigma below `limit` (NaN/inf: not trusted); fractions of the whole grid and of
// the pixels within `r` of the half-diagonal.
TrustedRegion TrustedRegionOf(
    const std::vector<Eigen::Vector2d>& px, const std::vector<double>& v, int w, int h, double limit, double r) {
  const Eigen::Vector2d c((w - 1) / 2.0, (h - 1) / 2.0);
  TrustedRegion t;
  int n = 0, in = 0, in_ok = 0, ok = 0;
  for (size_t i = 0; i < px.size() && i < v.size(); ++i) {
    const bool good = std::isfinite(v[i]) && v[i] < limit;
    t.trusted.push_back(good);
    ++n;
    ok += good;
    if ((px[i] - c).norm() <= r * c.norm()) {
      ++in;
      in_ok += good;
    }
  }
  t.fraction = n ? double(ok) / n : 0.0;
  t.working_fraction = in ? double(in_ok) / in : 0.0;
  return t;
}

std::string Join(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i == 0 ? "" : (i + 1 == v.size() ? " and " : ", ")) + v[i];
  return s;
}

double CovOf(const fitting::UncertaintyMap& u, int param_index) {
  for (size_t k = 0; k < u.free_indices.size(); ++k)
    if (u.free_indices[k] == param_index) return u.intrinsics_covariance(k, k);
  return 0;  // fixed
}

nlohmann::json StatsJson(const fitting::UncertaintyMap& u) {
  if (!u.ok) return {{"ok", false}, {"message", u.message}};
  return {
      {"ok", true}, {"centre_px", u.centre_px}, {"median_px", u.median_px}, {"p90_px", u.p90_px}, {"max_px", u.max_px}};
}

// The verdict being built: its reasons (each makes the set unusable or poor), the advice by rank
// (most useful first: the mirror/swap fix, tilt, where to fill, closer, more views) and the two
// findings the general advice depends on.
struct VerdictState {
  SetVerdict* v = nullptr;
  bool unusable = false, poor = false;
  bool weak_focal = false, thin_coverage = false;
  std::map<int, std::vector<std::string>> advice;

  void Advise(int rank, const std::string& a) {
    auto& v2 = advice[rank];
    if (std::find(v2.begin(), v2.end(), a) == v2.end()) v2.push_back(a);
  }
  void AddReason(bool is_unusable, const std::string& r) {
    (is_unusable ? unusable : poor) = true;
    v->reasons.push_back(r);
  }
  // The eye's fx, fy, cx, cy are refused for `why`.
  void RefuseFocal(int e, const std::string& why) {
    for (const char* n : {"fx", "fy", "cx", "cy"}) v->refused.push_back({std::string(kEye[e]) + "." + n, why});
  }
};

// Uncertainty of eye e: corners per zone, the projection uncertainty at infinity, at the boards
// and at the judged range, the trusted region, and the focal length's and principal point's sigma.
void JudgeEyeUncertainty(int e,
                         const fitting::StereoFit& fit,
                         const std::vector<calib::View> views[2],
                         const std::vector<int>& fixed,
                         const fitting::UncertaintyMapOptions& uo,
                         double length_unit_m,
                         const SetVerdictOptions& vo,
                         VerdictState* state) {
  VerdictState& st = *state;
  SetVerdict& v = *st.v;
  const std::string region =
      "within " + fitting::FixedOrDash(100 * vo.working_radius_fraction, 0) + " % of the half-diagonal";
  EyeVerdictMetrics& m = v.eye[e];
  const fitting::IntrinsicsFit& f = fit.per_eye[e];
  const int W = f.camera.width, H = f.camera.height;
  const std::string eye = kEye[e];
  m.corners_per_zone.assign(9, 0);
  for (const auto& view : views[e])
    for (const auto& px : view.pixels) ++m.corners_per_zone[ZoneOf(px, W, H)];
  for (const auto& u : f.undetermined)
    if (!fitting::internal::IsHeldReason(u)) st.AddReason(false, eye + " eye: not determined: " + u);
  m.at_infinity = fitting::ComputeUncertaintyMap(f, views[e], fixed, uo);
  m.board_distance = fitting::MedianBoardDistance(f);
  fitting::UncertaintyMapOptions ub = uo;
  ub.distance_m = m.board_distance;
  m.at_boards = fitting::ComputeUncertaintyMap(f, views[e], fixed, ub);
  if (!m.at_infinity.ok) {
    st.weak_focal = st.thin_coverage = true;
    st.AddReason(false, eye + " eye: the set does not determine the lens: " + m.at_infinity.message);
    st.RefuseFocal(e, v.reasons.back());
    return;
  }
  m.working_p90_px = P90Within(m.at_infinity.pixels, m.at_infinity.sigma_px, W, H, vo.working_radius_fraction);
  if (m.at_boards.ok)
    m.working_p90_boards_px = P90Within(m.at_boards.pixels, m.at_boards.sigma_px, W, H, vo.working_radius_fraction);
  int within = 0;
  for (double x : m.at_infinity.sigma_px) within += x <= 1.0;
  m.image_fraction_within_1px = static_cast<double>(within) / std::max<size_t>(1, m.at_infinity.sigma_px.size());
  const auto& p = f.camera.params;
  m.relative_focal_sigma =
      std::max(std::sqrt(CovOf(m.at_infinity, 0)) / p[0], std::sqrt(CovOf(m.at_infinity, 1)) / p[1]);
  m.principal_sigma_px = std::max(std::sqrt(CovOf(m.at_infinity, 2)), std::sqrt(CovOf(m.at_infinity, 3)));
  // The trusted region: predicted uncertainty at the judged range against the observed noise.
  m.noise_px = f.corner_sigma_px;
  m.trust_limit_px = vo.trust_threshold_noise * m.noise_px;
  m.judged_distance = length_unit_m > 0 ? vo.judged_range_m / length_unit_m : 0.0;
  if (m.judged_distance > 0) {
    fitting::UncertaintyMapOptions ur = uo;
    ur.distance_m = m.judged_distance;
    m.at_range = fitting::ComputeUncertaintyMap(f, views[e], fixed, ur);
  } else {
    m.at_range = m.at_infinity;
  }
  const std::string range_text =
      m.judged_distance > 0 ? "at " + fitting::FixedOrDash(vo.judged_range_m, 2) + " m" : "at infinity";
  if (!m.at_range.ok) {
    st.thin_coverage = true;
    st.AddReason(false, eye + " eye: no projection uncertainty " + range_text + ": " + m.at_range.message);
    return;
  }
  const TrustedRegion t =
      TrustedRegionOf(m.at_range.pixels, m.at_range.sigma_px, W, H, m.trust_limit_px, vo.working_radius_fraction);
  m.trusted = t.trusted;
  m.trusted_fraction = t.fraction;
  m.trusted_working_fraction = t.working_fraction;
  m.working_p90_range_px = P90Within(m.at_range.pixels, m.at_range.sigma_px, W, H, vo.working_radius_fraction);
  if (!(m.trusted_working_fraction >= vo.min_trusted_working_fraction)) {
    st.thin_coverage = true;
    st.AddReason(false,
                 eye + " eye: the model is trusted over " + fitting::FixedOrDash(100 * m.trusted_working_fraction, 0) +
                     " % of the working region only (" + region + "; limit " +
                     fitting::FixedOrDash(100 * vo.min_trusted_working_fraction, 0) +
                     " %): there the predicted projection "
                     "uncertainty " +
                     range_text + " exceeds " + fitting::FixedOrDash(vo.trust_threshold_noise, 1) +
                     " x the corner noise (" + fitting::FixedOrDash(m.trust_limit_px, 2) + " px; p90 " +
                     fitting::FixedOrDash(m.working_p90_range_px, 2) + " px; " +
                     fitting::FixedOrDash(100 * m.trusted_fraction, 0) + " % of the whole image trusted)");
    if (m.working_p90_px > 2 * m.working_p90_boards_px) st.weak_focal = true;  // fine at the boards, not beyond
  }
  if (m.relative_focal_sigma > vo.max_relative_focal_sigma) {
    st.weak_focal = true;
    st.AddReason(false,
                 eye + " eye: the focal length is known only to " +
                     fitting::FixedOrDash(100 * m.relative_focal_sigma, 2) + " % (limit " +
                     fitting::FixedOrDash(100 * vo.max_relative_focal_sigma, 2) + " %)");
    st.RefuseFocal(e, v.reasons.back());
  }
  if (m.principal_sigma_px > vo.max_principal_sigma_px) {
    st.weak_focal = true;
    st.AddReason(false,
                 eye + " eye: the principal point is known only to " + fitting::FixedOrDash(m.principal_sigma_px, 1) +
                     " px (limit " + fitting::FixedOrDash(vo.max_principal_sigma_px, 1) + " px)");
  }
}

// Cross-validation: two interleaved halves, each calibrated alone, compared per eye.
void CrossCheckHalves(const fitting::StereoFit& fit,
                      const std::vector<calib::View> views[2],
                      const fitting::StereoFitOptions& options,
                      double length_unit_m,
                      const SetVerdictOptions& vo,
                      VerdictState* state) {
  VerdictState& st = *state;
  SetVerdict& v = *st.v;
  std::vector<int> frames = fit.paired_frames;
  std::sort(frames.begin(), frames.end());
  if (v.sanity.mirrored_or_swapped) {
    v.split_message = "not cross-checked: the geometry is impossible (mirrored or swapped)";
  } else if (static_cast<int>(frames.size()) < vo.min_pairs_to_split) {
    v.split_message = std::to_string(frames.size()) + " pairs: too few to calibrate two halves (at least " +
                      std::to_string(vo.min_pairs_to_split) + ")";
    st.AddReason(false, "nothing checks the set against itself: " + v.split_message);
    st.Advise(4, "capture 15-25 pairs, so that the set can be checked against itself");
  } else {
    std::set<int> half[2];
    for (size_t i = 0; i < frames.size(); ++i) half[i % 2].insert(frames[i]);
    fitting::StereoFit hf[2];
    bool ok = true;
    for (int h = 0; h < 2; ++h) {
      std::vector<calib::View> hv[2];
      for (int e = 0; e < 2; ++e)
        for (const auto& view : views[e])
          if (half[h].count(view.frame_index)) hv[e].push_back(view);
      hf[h] = fitting::FitStereo(hv[0], hv[1], options);
      if (!hf[h].ok && ok) {
        ok = false;
        v.split_message = "half " + std::string(h == 0 ? "A" : "B") + " (" + std::to_string(half[h].size()) +
                          " pairs) cannot be calibrated alone: " + hf[h].message;
      }
    }
    if (!ok) {
      st.AddReason(false, "nothing checks the set against itself: " + v.split_message);
      st.weak_focal = true;
      st.Advise(4, "capture more pairs (15-25), each with the board in a new place and orientation");
    } else {
      v.split = true;
      if (length_unit_m > 0) {
        for (int h = 0; h < 2; ++h) {
          std::vector<double> q = hf[h].cameras[0].params;
          q.insert(q.end(), hf[h].cameras[1].params.begin(), hf[h].cameras[1].params.end());
          const Eigen::AngleAxisd aa(hf[h].right_from_left.rotation);
          const Eigen::Vector3d rv = aa.angle() * aa.axis();
          for (int i = 0; i < 3; ++i) q.push_back(rv[i]);
          for (int i = 0; i < 3; ++i) q.push_back(hf[h].right_from_left.translation[i] * length_unit_m);
          v.half_rig.push_back(q);
        }
      }
      const double ba = hf[0].right_from_left.translation.norm(), bb = hf[1].right_from_left.translation.norm();
      v.half_baseline_diff = std::abs(ba - bb) / std::max(1e-12, fit.right_from_left.translation.norm());
      for (int e = 0; e < 2; ++e) {
        EyeVerdictMetrics& m = v.eye[e];
        const std::string eye = kEye[e];
        const int W = fit.per_eye[e].camera.width, H = fit.per_eye[e].camera.height;
        m.halves = CompareProjection(
            hf[0].cameras[e], hf[1].cameras[e], vo.grid_cols, vo.grid_rows, vo.working_radius_fraction);
        const auto& pa = hf[0].cameras[e].params;
        const auto& pb = hf[1].cameras[e].params;
        m.half_focal_diff = std::max(std::abs(pa[0] - pb[0]) / pa[0], std::abs(pa[1] - pb[1]) / pa[1]);
        if (m.halves.ok) {
          m.halves_working_p90_px = P90Within(m.halves.pixels, m.halves.diff_px, W, H, vo.working_radius_fraction);
          if (m.working_p90_px > 0) m.covariance_scale = m.halves_working_p90_px / (2 * m.working_p90_px);
        }
        if (!m.halves.ok || !(m.halves_working_p90_px <= vo.max_half_diff_px)) {
          st.AddReason(false,
                       eye + " eye: two halves of the set, calibrated alone, project " +
                           (m.halves.ok ? fitting::FixedOrDash(m.halves_working_p90_px, 2) +
                                              " px apart over 10 % of the working region (limit " +
                                              fitting::FixedOrDash(vo.max_half_diff_px, 2) + " px)"
                                        : "too differently to compare (" + m.halves.message + ")"));
          st.Advise(4,
                    "add views (15-25 pairs in all) that differ from each other: board near and far, in every "
                    "part of the image, tilted several ways");
        }
        if (m.half_focal_diff > vo.max_half_focal_diff) {
          st.weak_focal = true;
          st.AddReason(false,
                       eye + " eye: the halves' focal lengths differ by " +
                           fitting::FixedOrDash(100 * m.half_focal_diff, 2) + " % (limit " +
                           fitting::FixedOrDash(100 * vo.max_half_focal_diff, 1) + " %; fx " +
                           fitting::FixedOrDash(pa[0], 1) + " vs " + fitting::FixedOrDash(pb[0], 1) + " px)");
          st.RefuseFocal(e, v.reasons.back());
        }
      }
    }
  }
}

// Where the board never went: the 3 x 3 zones holding under 2 % of an eye's corners.
void AdviseCoverage(const SetVerdict& v, VerdictState* state) {
  VerdictState& st = *state;
  for (int e = 0; e < 2; ++e) {
    int total = 0;
    for (int c : v.eye[e].corners_per_zone) total += c;
    std::vector<std::string> zones;
    for (int z = 0; z < 9; ++z)
      if (v.eye[e].corners_per_zone[z] < 0.02 * std::max(1, total)) zones.push_back(kZone[z]);
    if (!zones.empty())
      st.Advise(2,
                "fill the " + Join(zones) + " of the " + kEye[e] +
                    " image: add views where the board reaches there (closer to the cameras, or moved off-centre)");
  }
  st.Advise(3, "bring the board closer so it fills more of the image in some views");
}

}  // namespace

bool SetVerdictOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (min_pairs < 1 || min_pairs_to_split < 2) return fail("min_pairs must be >= 1 and min_pairs_to_split >= 2");
  if (!(judged_range_m >= 0 && trust_threshold_noise > 0 && min_trusted_working_fraction >= 0 &&
        min_trusted_working_fraction <= 1))
    return fail("judged_range_m must be >= 0, trust_threshold_noise > 0, min_trusted_working_fraction in [0, 1]");
  if (!(max_relative_focal_sigma > 0 && max_principal_sigma_px > 0 && max_half_diff_px > 0 && max_half_focal_diff > 0))
    return fail("every verdict limit must be > 0");
  if (!(working_radius_fraction > 0 && working_radius_fraction <= 1))
    return fail("working_radius_fraction must be in (0, 1]");
  if (grid_cols < 3 || grid_rows < 3) return fail("the uncertainty grid must be at least 3x3");
  return rig.Check(why);
}

SetVerdict JudgeStereoSet(const fitting::StereoFit& fit,
                          const std::vector<calib::View> views[2],
                          const fitting::StereoFitOptions& options,
                          double length_unit_m,
                          const SetVerdictOptions& vo) {
  SetVerdict v;
  v.rig = vo.rig;
  std::string why;
  if (!vo.Check(&why)) throw std::invalid_argument("SetVerdictOptions: " + why);
  v.num_pairs = static_cast<int>(fit.paired_frames.size());
  v.judged_range_m = length_unit_m > 0 ? vo.judged_range_m : 0.0;
  v.trust_threshold_noise = vo.trust_threshold_noise;
  v.working_radius_fraction = vo.working_radius_fraction;
  VerdictState st;
  st.v = &v;
  if (!fit.ok) {
    st.AddReason(true, "the stereo fit failed: " + fit.message);
    v.advice.push_back("capture 15-25 pairs with the whole board visible in both eyes, tilted in different directions");
    v.status = "unusable";
    return v;
  }
  if (v.num_pairs < vo.min_pairs)
    st.AddReason(true,
                 "only " + std::to_string(v.num_pairs) + " pairs show the board in both eyes (< " +
                     std::to_string(vo.min_pairs) + ")");

  // Physical sanity.
  if (vo.recognise_rig) {
    const std::string why_not = WhyNotThisRig(fit.cameras, fit.right_from_left, length_unit_m, vo.rig);
    if (!why_not.empty()) {
      v.rig = RigExpectation::Generic();
      v.rig_note = "rig: not an " + vo.rig.name + " (" + why_not + "), so the set is judged as a " + v.rig.name +
                   " stereo pair; --rig " + vo.rig.name + " judges it against the " + vo.rig.name + " rig";
    }
  }
  v.sanity = CheckStereoSanity(fit.cameras, fit.right_from_left, length_unit_m, v.rig);
  for (const auto& f : v.sanity.findings) st.AddReason(f.unusable, f.message);

  // Uncertainty per eye.
  const auto fixed = fitting::internal::FixedIntrinsicIndices(options.intrinsics);
  fitting::UncertaintyMapOptions uo;
  uo.grid_cols = vo.grid_cols;
  uo.grid_rows = vo.grid_rows;
  for (int e = 0; e < 2; ++e) JudgeEyeUncertainty(e, fit, views, fixed, uo, length_unit_m, vo, &st);

  // Cross-validation: two interleaved halves, each calibrated alone.
  CrossCheckHalves(fit, views, options, length_unit_m, vo, &st);
  if (st.thin_coverage) AdviseCoverage(v, &st);
  if (st.weak_focal)
    st.Advise(1,
              "tilt the board 30-45 deg about its horizontal axis (top edge away from the cameras, then towards "
              "them) in some views and about its vertical axis in others: boards facing the cameras let the "
              "focal length trade against the board's distance");
  if (v.sanity.mirrored_or_swapped) st.Advise(0, "calibrate again with --mirror or --swap (see the reason above)");
  for (const auto& [rank, list] : st.advice) v.advice.insert(v.advice.end(), list.begin(), list.end());
  v.status = st.unusable ? "unusable" : (st.poor ? "poor" : "good");
  return v;
}

nlohmann::json SetVerdict::ToJson() const {
  nlohmann::json eyes = nlohmann::json::object();
  for (int e = 0; e < 2; ++e) {
    const EyeVerdictMetrics& m = eye[e];
    nlohmann::json h = nlohmann::json::object();
    if (m.halves.ok)
      h = {{"p90_px", m.halves.p90_px},
           {"max_px", m.halves.max_px},
           {"median_px", m.halves.median_px},
           {"focal_diff", m.half_focal_diff}};
    if (m.halves.ok) h["working_p90_px"] = m.halves_working_p90_px;
    nlohmann::json trusted = nlohmann::json::object();
    if (m.at_range.ok) {
      std::vector<double> xs, ys, sig;
      for (size_t i = 0; i < m.at_range.pixels.size(); ++i) {
        xs.push_back(m.at_range.pixels[i].x());
        ys.push_back(m.at_range.pixels[i].y());
        sig.push_back(std::isfinite(m.at_range.sigma_px[i]) ? m.at_range.sigma_px[i] : -1.0);
      }
      trusted = {{"range_m", judged_range_m},
                 {"noise_px", m.noise_px},
                 {"threshold_noise", trust_threshold_noise},
                 {"limit_px", m.trust_limit_px},
                 {"working_radius_fraction", working_radius_fraction},
                 {"fraction", m.trusted_fraction},
                 {"working_fraction", m.trusted_working_fraction},
                 {"working_p90_px", m.working_p90_range_px},
                 {"grid_cols", m.at_range.grid_cols},
                 {"grid_rows", m.at_range.grid_rows},
                 {"x_px", xs},
                 {"y_px", ys},
                 {"sigma_px", sig}};
    }
    eyes[kEye[e]] = {{"projection_sigma_at_infinity", StatsJson(m.at_infinity)},
                     {"projection_sigma_at_boards", StatsJson(m.at_boards)},
                     {"working_p90_px", m.working_p90_px},
                     {"working_p90_boards_px", m.working_p90_boards_px},
                     {"image_fraction_within_1px", m.image_fraction_within_1px},
                     {"covariance_scale", m.covariance_scale},
                     {"board_distance", m.board_distance},
                     {"relative_focal_sigma", m.relative_focal_sigma},
                     {"principal_sigma_px", m.principal_sigma_px},
                     {"halves", h},
                     {"trusted_region", trusted},
                     {"corners_per_zone", m.corners_per_zone}};
  }
  return {{"status", status},
          {"reasons", reasons},
          {"advice", advice},
          {"metrics",
           {{"pairs", num_pairs},
            {"split", split},
            {"split_message", split_message},
            {"half_baseline_diff", half_baseline_diff},
            {"eyes", eyes}}}};
}

void AppendVerdictToResult(const SetVerdict& v, fitting::CalibrationResult* r) {
  r->verdict = v.ToJson();
  r->verdict["rig"] = v.rig.name;
  r->verdict["rig_note"] = v.rig_note;
  if (!v.rig_note.empty()) r->warnings.push_back(v.rig_note);
  for (const auto& [name, why] : v.refused) {
    for (auto& p : r->parameters) {
      if (p.name != name || !p.determined) continue;
      p.determined = false;
      p.sigma = std::numeric_limits<double>::quiet_NaN();
      p.note = "refused by the set verdict: " + why;
    }
  }
  AppendSanityToResult(v.sanity, v.rig, r);
  if (v.half_rig.size() == 2)
    r->diagnostics["cross_validation"] = {
        {"layout", "left params, right params, rotation vector of R [rad], T [m] (stereo.full_covariance's order)"},
        {"halves", v.half_rig}};
  for (const auto& reason : v.reasons)
    if (std::find(r->warnings.begin(), r->warnings.end(), "sanity: " + reason) == r->warnings.end())
      r->warnings.push_back("verdict " + v.status + ": " + reason);
}

}  // namespace owlcal::evaluation
