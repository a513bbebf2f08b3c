#include "evaluation/reference_comparison.h"

#include <cmath>
#include <map>
#include <sstream>

#include <opencv2/calib3d.hpp>

#include "io/json_strict.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {

// One calibration's comparable numbers: fx fy cx cy per eye, rotation vector [deg], T [display unit].
struct Numbers {
  double cam[2][4] = {{0, 0, 0, 0}, {0, 0, 0, 0}};
  Eigen::Vector3d rvec_deg = Eigen::Vector3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  bool has_t = false;
};

Numbers FromOpenCv(const cv::Mat& m1, const cv::Mat& m2, const cv::Mat& r, const cv::Mat& t, double t_scale) {
  Numbers n;
  const cv::Mat* m[2] = {&m1, &m2};
  for (int e = 0; e < 2; ++e) {
    n.cam[e][0] = m[e]->at<double>(0, 0);
    n.cam[e][1] = m[e]->at<double>(1, 1);
    n.cam[e][2] = m[e]->at<double>(0, 2);
    n.cam[e][3] = m[e]->at<double>(1, 2);
  }
  cv::Mat rv;
  cv::Rodrigues(r, rv);
  for (int i = 0; i < 3; ++i) n.rvec_deg[i] = rv.at<double>(i) * kRadToDeg;
  if (t_scale > 0) {
    for (int i = 0; i < 3; ++i) n.t[i] = t.at<double>(i) * t_scale;
    n.has_t = true;
  }
  return n;
}

// Factor from `from` to `to` lengths (1 when equal; m <-> mm); 0 when unknown.
double LengthFactor(const std::string& from, const std::string& to) {
  if (from == to) return 1;
  if (from == "mm" && to == "m") return 1e-3;
  if (from == "m" && to == "mm") return 1e3;
  return 0;
}

std::string FixedDigits(double v, int digits) {
  if (!std::isfinite(v)) return "";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

// The corners both eyes saw in the same frame, as OpenCV's stereoCalibrate takes them (pairs
// with too few shared corners left out).
struct StereoCornerPairs {
  std::vector<std::vector<cv::Point3f>> obj;
  std::vector<std::vector<cv::Point2f>> img[2];
};
StereoCornerPairs PairCorners(const std::vector<calib::View>& left_views, const std::vector<calib::View>& right_views) {
  StereoCornerPairs pairs;
  std::vector<std::vector<cv::Point3f>>& obj = pairs.obj;
  std::vector<std::vector<cv::Point2f>>* img = pairs.img;
  std::map<int, const calib::View*> right_of;
  for (const auto& v : right_views) right_of[v.frame_index] = &v;
  for (const auto& l : left_views) {
    const auto it = right_of.find(l.frame_index);
    if (it == right_of.end()) continue;
    const calib::View& r = *it->second;
    std::map<int, size_t> r_index;
    for (size_t i = 0; i < r.corner_ids.size(); ++i) r_index[r.corner_ids[i]] = i;
    std::vector<cv::Point3f> o;
    std::vector<cv::Point2f> p[2];
    for (size_t i = 0; i < l.corner_ids.size(); ++i) {
      const auto j = r_index.find(l.corner_ids[i]);
      if (j == r_index.end()) continue;
      const Eigen::Vector3d& x = l.points_in_target[i];
      o.emplace_back(float(x.x()), float(x.y()), float(x.z()));
      p[0].emplace_back(float(l.pixels[i].x()), float(l.pixels[i].y()));
      p[1].emplace_back(float(r.pixels[j->second].x()), float(r.pixels[j->second].y()));
    }
    if (o.size() < 6) continue;
    obj.push_back(o);
    img[0].push_back(p[0]);
    img[1].push_back(p[1]);
  }
  return pairs;
}

// B: the reference's program (its flags) on owlcal's corners.
Numbers CalibrateLikeReference(const StereoCornerPairs& pairs,
                               const cv::Size& size,
                               const ReferenceComparisonOptions& options,
                               const cv::TermCriteria& crit,
                               double fit_to_display,
                               ReferenceComparison* out) {
  ReferenceComparison& c = *out;
  const auto& obj = pairs.obj;
  const auto* img = pairs.img;
  cv::Mat m[2], dist[2], r, t, e, f;
  for (int k = 0; k < 2; ++k) {
    m[k] = cv::initCameraMatrix2D(obj, img[k], size, 0);
    dist[k] = cv::Mat::zeros(1, 8, CV_64F);
  }
  const int flags = options.reference_flags >= 0
                        ? options.reference_flags
                        : cv::CALIB_FIX_ASPECT_RATIO | cv::CALIB_ZERO_TANGENT_DIST | cv::CALIB_USE_INTRINSIC_GUESS |
                              cv::CALIB_SAME_FOCAL_LENGTH | cv::CALIB_RATIONAL_MODEL | cv::CALIB_FIX_K3 |
                              cv::CALIB_FIX_K4 | cv::CALIB_FIX_K5;
  c.rms_reference_model_px =
      cv::stereoCalibrate(obj, img[0], img[1], m[0], dist[0], m[1], dist[1], size, r, t, e, f, flags, crit);
  return FromOpenCv(m[0], m[1], r, t, fit_to_display);
}

// D: owlcal's lens model in OpenCV: each eye alone (cv::calibrateCamera), then jointly.
Numbers CalibrateWithOwlcalModel(const StereoCornerPairs& pairs,
                                 const cv::Size& size,
                                 const cv::TermCriteria& crit,
                                 double fit_to_display,
                                 ReferenceComparison* out) {
  ReferenceComparison& c = *out;
  const auto& obj = pairs.obj;
  const auto* img = pairs.img;
  const bool rational = c.owlcal_model == "opencv8";
  const int model_flags = rational ? cv::CALIB_RATIONAL_MODEL : 0;
  cv::Mat m[2], dist[2], r, t, e, f;
  for (int k = 0; k < 2; ++k) {
    std::vector<cv::Mat> rv, tv;
    m[k] = cv::initCameraMatrix2D(obj, img[k], size, 0);
    dist[k] = cv::Mat::zeros(1, rational ? 8 : 5, CV_64F);
    cv::calibrateCamera(obj, img[k], size, m[k], dist[k], rv, tv, model_flags | cv::CALIB_USE_INTRINSIC_GUESS, crit);
  }
  c.rms_owlcal_model_px = cv::stereoCalibrate(obj,
                                              img[0],
                                              img[1],
                                              m[0],
                                              dist[0],
                                              m[1],
                                              dist[1],
                                              size,
                                              r,
                                              t,
                                              e,
                                              f,
                                              model_flags | cv::CALIB_USE_INTRINSIC_GUESS,
                                              crit);
  return FromOpenCv(m[0], m[1], r, t, fit_to_display);
}

// A fit's numbers in the comparison's units.
Numbers NumbersOfFit(const fitting::StereoFit& f, double fit_to_display) {
  Numbers n;
  for (int e = 0; e < 2; ++e)
    for (int i = 0; i < 4; ++i) n.cam[e][i] = f.cameras[e].params[i];
  const Eigen::AngleAxisd aa(f.right_from_left.rotation);
  n.rvec_deg = aa.angle() * aa.axis() * kRadToDeg;
  n.t = f.right_from_left.translation * fit_to_display;
  n.has_t = true;
  return n;
}

// The rows: each eye's fx, fy, cx, cy, the rotation vector and, with translations on both sides,
// T and the baseline; each with owlcal's sigma.
void AddComparisonRows(const fitting::StereoFit& fit,
                       const Numbers& a,
                       const Numbers& b,
                       const Numbers& d,
                       const Numbers& cc,
                       const Numbers& ee,
                       const std::string& display_unit,
                       double fit_to_display,
                       ReferenceComparison* out) {
  ReferenceComparison& c = *out;
  auto sigma_of = [&](const std::string& name, double scale) {
    for (size_t i = 0; i < fit.param_names.size() && i < fit.sigmas.size(); ++i)
      if (fit.param_names[i] == name) return fit.determined[i] ? fit.sigmas[i] * scale : NAN;
    return double(NAN);
  };
  const char* eye[2] = {"left", "right"};
  const char* cam_names[4] = {"fx", "fy", "cx", "cy"};
  for (int e = 0; e < 2; ++e)
    for (int i = 0; i < 4; ++i) {
      ReferenceComparisonRow row;
      row.name = std::string(eye[e]) + "." + cam_names[i];
      row.unit = "px";
      row.reference = a.cam[e][i];
      row.opencv_reference_model = b.cam[e][i];
      row.opencv_owlcal_model = d.cam[e][i];
      row.owlcal = cc.cam[e][i];
      row.owlcal_flat = ee.cam[e][i];
      row.owlcal_sigma = sigma_of(row.name, 1);
      c.rows.push_back(row);
    }
  const char* axes = "xyz";
  for (int i = 0; i < 3; ++i) {
    ReferenceComparisonRow row;
    row.name = std::string("stereo.r") + axes[i];
    row.unit = "deg";
    row.reference = a.rvec_deg[i];
    row.opencv_reference_model = b.rvec_deg[i];
    row.opencv_owlcal_model = d.rvec_deg[i];
    row.owlcal = cc.rvec_deg[i];
    row.owlcal_flat = ee.rvec_deg[i];
    row.owlcal_sigma = sigma_of(row.name, kRadToDeg);
    c.rows.push_back(row);
  }
  if (a.has_t && b.has_t && d.has_t) {
    for (int i = 0; i < 3; ++i) {
      ReferenceComparisonRow row;
      row.name = std::string("stereo.t") + axes[i];
      row.unit = display_unit;
      row.reference = a.t[i];
      row.opencv_reference_model = b.t[i];
      row.opencv_owlcal_model = d.t[i];
      row.owlcal = cc.t[i];
      row.owlcal_flat = ee.t[i];
      row.owlcal_sigma = sigma_of(row.name, fit_to_display);
      c.rows.push_back(row);
    }
    ReferenceComparisonRow row;
    row.name = "stereo.baseline";
    row.unit = display_unit;
    row.reference = a.t.norm();
    row.opencv_reference_model = b.t.norm();
    row.opencv_owlcal_model = d.t.norm();
    row.owlcal = cc.t.norm();
    row.owlcal_flat = ee.t.norm();
    // sigma of |T| = g' C_T g, g = T / |T|, from the covariance's T block.
    row.owlcal_sigma = NAN;
    int t0 = -1;
    for (size_t i = 0; i < fit.param_names.size(); ++i)
      if (fit.param_names[i] == "stereo.tx") t0 = int(i);
    if (t0 >= 0 && fit.covariance.rows() >= t0 + 3 && fit.determined[t0] && fit.determined[t0 + 1] &&
        fit.determined[t0 + 2]) {
      const Eigen::Vector3d g = fit.right_from_left.translation.normalized();
      const double var = g.dot(fit.covariance.block<3, 3>(t0, t0) * g);
      if (var >= 0) row.owlcal_sigma = std::sqrt(var) * fit_to_display;
    }
    c.rows.push_back(row);
  }
}

// The shares of the difference, sigma-weighted, and the message.
void ShareDifferences(ReferenceComparison* out) {
  ReferenceComparison& c = *out;
  // Shares, sigma-weighted (the baseline is a function of T: left out so T is not counted twice).
  double den = 0, det = 0, mod = 0, est = 0, bow = 0;
  for (const auto& r : c.rows) {
    if (r.name == "stereo.baseline" || !(r.owlcal_sigma > 0)) continue;
    const double w = 1.0 / (r.owlcal_sigma * r.owlcal_sigma);
    den += w * r.Total() * r.Total();
    det += w * r.Detection() * r.Total();
    mod += w * r.Model() * r.Total();
    est += w * r.Estimator() * r.Total();
    bow += w * r.Bow() * r.Total();
    ++c.num_weighted;
  }
  c.chi2_total = den;
  if (den > 0) {
    c.share_detection = det / den;
    c.share_model = mod / den;
    c.share_estimator = est / den;
    c.share_bow = bow / den;
  }
  c.ok = true;
  const ReferenceComparisonRow* worst = nullptr;
  for (const auto& r : c.rows)
    if (r.owlcal_sigma > 0 &&
        (!worst || std::abs(r.Total() / r.owlcal_sigma) > std::abs(worst->Total() / worst->owlcal_sigma)))
      worst = &r;
  std::ostringstream s;
  s << "Against the " << c.reference_name << " reference (" << c.reference_model << "), over " << c.num_weighted
    << " parameters weighted by owlcal's sigma: the lens-model choice (" << c.owlcal_model << ") explains "
    << FixedDigits(100 * c.share_model, 0) << " % of the difference, the corner detection "
    << FixedDigits(100 * c.share_detection, 0) << " %, the board's bow " << FixedDigits(100 * c.share_bow, 0)
    << " %, owlcal's estimator (robust loss, per-eye noise) " << FixedDigits(100 * c.share_estimator, 0) << " %";
  if (worst)
    s << "; largest: " << worst->name << " " << FixedDigits(worst->Total(), 3) << " " << worst->unit << " ("
      << FixedDigits(worst->Total() / worst->owlcal_sigma, 1) << " sigma)";
  c.message = s.str();
}

}  // namespace

ReferenceComparison CompareWithReference(const std::vector<calib::View>& left_views,
                                         const std::vector<calib::View>& right_views,
                                         const fitting::StereoFit& fit,
                                         const fitting::StereoFit* flat_fit,
                                         const fitting::OpenCvStereoCalibration& reference,
                                         const ReferenceComparisonOptions& options) {
  ReferenceComparison c;
  c.reference_name = options.reference_name;
  c.reference_model = options.reference_model;
  c.length_unit = fit.length_unit;
  if (!fit.ok) {
    c.message = "owlcal's stereo fit failed: nothing to compare";
    return c;
  }
  if (!reference.HasIntrinsics() || !reference.HasExtrinsics()) {
    c.message = "the reference has no " + std::string(reference.HasIntrinsics() ? "R, T" : "M1, D1, M2, D2");
    return c;
  }
  c.owlcal_model = fit.cameras[0].model == models::DistortionModel::kOpenCv5 ? "opencv5" : "opencv8";
  const cv::Size size(fit.cameras[0].width, fit.cameras[0].height);
  if (reference.image_width > 0 && (reference.image_width != size.width || reference.image_height != size.height)) {
    c.message = "the reference is for " + std::to_string(reference.image_width) + "x" +
                std::to_string(reference.image_height) + " images, these are " + std::to_string(size.width) + "x" +
                std::to_string(size.height);
    return c;
  }

  // Pairs: the corners both eyes saw in the same frame.
  const StereoCornerPairs pairs = PairCorners(left_views, right_views);
  const auto& obj = pairs.obj;
  c.num_pairs = int(obj.size());
  if (c.num_pairs < 3) {
    c.message = "only " + std::to_string(c.num_pairs) + " pairs with corners in both eyes (need 3)";
    return c;
  }
  for (const auto& o : obj)
    for (const auto& x : o)
      if (x.z != 0) {
        c.message = "the target is not planar: OpenCV's calibration (the reference's solver) needs a planar one";
        return c;
      }

  // Lengths: shown in mm when the fit is in metres, else in the fit's unit.
  const std::string display_unit = fit.length_unit == "m" ? "mm" : fit.length_unit;
  const double fit_to_display = LengthFactor(fit.length_unit, display_unit);
  const double ref_to_display = LengthFactor(reference.length_unit, display_unit);
  if (ref_to_display == 0)
    c.notes.push_back("the reference's lengths are in '" + reference.length_unit + "', the fit's in '" +
                      fit.length_unit + "': translations are not compared");

  const cv::TermCriteria crit(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-5);
  Numbers a, b, d, cc, ee;
  try {
    a = FromOpenCv(reference.M1, reference.M2, reference.R, reference.T, ref_to_display);
    // B: the reference's program on owlcal's corners.
    b = CalibrateLikeReference(pairs, size, options, crit, fit_to_display, &c);
    // D: owlcal's lens model in OpenCV: each eye alone (cv::calibrateCamera), then jointly.
    d = CalibrateWithOwlcalModel(pairs, size, crit, fit_to_display, &c);
  } catch (const cv::Exception& ex) {
    c.message = std::string("OpenCV's calibration failed: ") + ex.what();
    return c;
  }
  // C: owlcal's fit; E: the same with a flat board.
  cc = NumbersOfFit(fit, fit_to_display);
  c.rms_owlcal_px = fit.rms_joint_px;
  c.bowed = fit.board_warp_fitted;
  const bool flat_ok = c.bowed && flat_fit && flat_fit->ok;
  ee = flat_ok ? NumbersOfFit(*flat_fit, fit_to_display) : cc;
  c.rms_owlcal_flat_px = flat_ok ? flat_fit->rms_joint_px : fit.rms_joint_px;
  if (c.bowed && !flat_ok)
    c.notes.push_back(
        "owlcal fitted the board's bow but no flat fit was given: the bow is counted in the estimator part");

  AddComparisonRows(fit, a, b, d, cc, ee, display_unit, fit_to_display, &c);

  ShareDifferences(&c);
  return c;
}

nlohmann::json ReferenceComparisonToJson(const ReferenceComparison& c) {
  nlohmann::json j = {{"ok", c.ok},
                      {"message", c.message},
                      {"reference", c.reference_name},
                      {"reference_model", c.reference_model},
                      {"owlcal_model", c.owlcal_model},
                      {"num_pairs", c.num_pairs},
                      {"notes", c.notes}};
  if (!c.ok) return j;
  j["rms_px"] = {{"opencv_reference_model", c.rms_reference_model_px},
                 {"opencv_owlcal_model", c.rms_owlcal_model_px},
                 {"owlcal_flat", c.rms_owlcal_flat_px},
                 {"owlcal", c.rms_owlcal_px}};
  j["bowed"] = c.bowed;
  j["share"] = {{"detection", c.share_detection},
                {"model", c.share_model},
                {"estimator", c.share_estimator},
                {"bow", c.share_bow}};
  j["chi2_total"] = c.chi2_total;
  j["num_weighted"] = c.num_weighted;
  nlohmann::json rows = nlohmann::json::array();
  for (const auto& r : c.rows)
    rows.push_back({{"name", r.name},
                    {"unit", r.unit},
                    {"reference", r.reference},
                    {"opencv_reference_model", r.opencv_reference_model},
                    {"opencv_owlcal_model", r.opencv_owlcal_model},
                    {"owlcal_flat", r.owlcal_flat},
                    {"owlcal", r.owlcal},
                    {"owlcal_sigma", io::JsonNumber(r.owlcal_sigma)},
                    {"total", r.Total()},
                    {"detection", r.Detection()},
                    {"model", r.Model()},
                    {"estimator", r.Estimator()},
                    {"bow", r.Bow()}});
  j["rows"] = rows;
  return j;
}

std::string ReferenceComparisonMarkdown(const ReferenceComparison& c) {
  std::ostringstream s;
  s << "## Against the reference calibration (" << c.reference_name << ")\n\n";
  if (!c.ok) {
    s << "Not compared: " << c.message << "\n";
    return s.str();
  }
  s << c.message << ".\n\n"
    << "A = the reference; B = OpenCV with the reference's flags on owlcal's corners (RMS "
    << FixedDigits(c.rms_reference_model_px, 4) << " px); D = OpenCV with owlcal's model " << c.owlcal_model << " (RMS "
    << FixedDigits(c.rms_owlcal_model_px, 4) << " px); E = owlcal with a flat board (RMS "
    << FixedDigits(c.rms_owlcal_flat_px, 4) << " px); C = owlcal (RMS " << FixedDigits(c.rms_owlcal_px, 4)
    << " px). detection = B - A, model = D - B, estimator = E - D, bow = C - E; they add up to C - A.\n\n"
    << "| parameter | unit | reference A | owlcal C | sigma | C - A | (C - A) / sigma | detection | model | estimator "
       "| bow |\n"
    << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const auto& r : c.rows) {
    const int dig = r.unit == "px" ? 2 : 3;
    s << "| " << r.name << " | " << r.unit << " | " << FixedDigits(r.reference, dig + 1) << " | "
      << FixedDigits(r.owlcal, dig + 1) << " | " << FixedDigits(r.owlcal_sigma, dig + 1) << " | "
      << FixedDigits(r.Total(), dig) << " | "
      << (r.owlcal_sigma > 0 ? FixedDigits(r.Total() / r.owlcal_sigma, 1) : std::string()) << " | "
      << FixedDigits(r.Detection(), dig) << " | " << FixedDigits(r.Model(), dig) << " | "
      << FixedDigits(r.Estimator(), dig) << " | " << FixedDigits(r.Bow(), dig) << " |\n";
  }
  for (const auto& n : c.notes) s << "\nNote: " << n << "\n";
  return s.str();
}

}  // namespace owlcal::evaluation
