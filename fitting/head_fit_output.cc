// The outputs of FitHead (declared in fitting/head_problem.h): the head model, the named
// parameters with sigma or the reason they are not determined, the IPD, the covariance of the
// determined parameters, and the diagnostics.
#include "fitting/head_problem.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>

#include "models/units.h"

namespace owlcal::fitting::internal {
namespace {

using models::kLeftEye;
using models::kNumServos;
using models::kRightEye;

// "a, b, servo.Rx.*": servo.X.<all five> written once as servo.X.*.
std::string JoinNames(const std::vector<std::string>& names) {
  std::map<std::string, int> servo_count;
  for (const std::string& n : names) {
    if (n.rfind("servo.", 0) == 0) servo_count[n.substr(0, n.rfind('.'))]++;
  }
  std::vector<std::string> out;
  std::set<std::string> done;
  for (const std::string& n : names) {
    if (n.rfind("servo.", 0) == 0) {
      const std::string prefix = n.substr(0, n.rfind('.'));
      if (servo_count[prefix] == 5) {
        if (done.insert(prefix).second) out.push_back(prefix + ".*");
        continue;
      }
    }
    out.push_back(n);
  }
  std::string s;
  for (size_t i = 0; i < out.size(); ++i) s += (i ? ", " : "") + out[i];
  return s;
}

models::HeadModel HeadModelOf(const HeadState& s, const models::HeadModel& initial, const models::RobotConfig& robot) {
  models::HeadModel head = initial;
  for (int i = 0; i < kNumServos; ++i) {
    std::copy_n(s.servo[i].values.begin(), 5, head.servo_params[i].begin());
    head.directions[i] = robot.servos[i].direction;
  }
  for (int e = 0; e < 2; ++e) {
    double c[3];
    EyeCentreOfCentres(s.centres.data(), e, c);
    head.geometry.centre_in_head[e] = Eigen::Vector3d(c[0], c[1], c[2]);
    head.geometry.cam_from_eye[e] = CamFromEyeOfMount(s.mount[e].data());
    head.intrinsics[e].params = s.camera[e].values;
  }
  return head;
}

// Every entry of the head blocks as a Parameter (intrinsics only when fitted): value in the
// result's unit, sigma from the covariance, or why it is not determined; and the covariance of
// the determined ones in result units (fit->param_names, fit->covariance).
void ReportBlockParameters(const HeadState& s, const HeadCovariance& cov, bool with_intrinsics, HeadFit* out) {
  HeadFit& fit = *out;
  CalibrationResult& result = fit.result;
  const Eigen::MatrixXd& cov_tangent = cov.analysis.covariance;
  const auto& tangent_of = cov.tangent_of;
  // Flat covariance in report units over the free, determined head parameters.
  std::vector<int> flat_tangent;
  std::vector<double> flat_scale;
  auto add_block_params = [&](const Block& b, bool report) {
    for (int i = 0; i < b.size(); ++i) {
      Parameter p;
      p.name = b.names[i];
      p.value = b.values[i] * b.scale[i];
      p.unit = b.units[i];
      auto it = tangent_of.find({&b, i});
      if (b.fixed[i] || it == tangent_of.end()) {
        p.determined = false;
        p.sigma = kNaN;
        p.note = b.fixed_note[i].empty() ? "not determined" : b.fixed_note[i];
      } else if (!cov.analysis.determined[it->second]) {
        p.determined = false;
        p.sigma = kNaN;
        p.note = "not determined: " + cov.analysis.reasons[it->second];
      } else {
        p.sigma = std::sqrt(std::max(0.0, cov_tangent(it->second, it->second))) * b.scale[i];
        fit.param_names.push_back(p.name);
        flat_tangent.push_back(it->second);
        flat_scale.push_back(b.scale[i]);
      }
      if (report) result.Set(p);
    }
  };
  for (const Block& b : s.servo) add_block_params(b, true);
  add_block_params(s.centres, true);
  for (int e = 0; e < 2; ++e) {
    add_block_params(s.mount[e], true);
    add_block_params(s.camera[e], with_intrinsics);
  }
  for (const auto& [id, b] : s.warps) add_block_params(b, !b.AllFixed());
  const int nf = static_cast<int>(flat_tangent.size());
  fit.covariance.resize(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b)
      fit.covariance(a, b) = cov_tangent(flat_tangent[a], flat_tangent[b]) * flat_scale[a] * flat_scale[b];
}

// Derived parameters: right centre z (= left z, gauge), mount pitch (gauge), the IPD with its
// sigma from the centres' covariance.
void ReportDerivedParameters(const HeadState& s,
                             const HeadCovariance& cov,
                             const models::HeadModel& head,
                             CalibrationResult* out) {
  CalibrationResult& result = *out;
  const Eigen::MatrixXd& cov_tangent = cov.analysis.covariance;
  const auto& tangent_of = cov.tangent_of;
  const Parameter* lz = result.Find("head.left.centre_z_mm");
  Parameter rz = *lz;
  rz.name = "head.right.centre_z_mm";
  rz.note = "equal to head.left.centre_z_mm by convention (head yaw gauge: x axis along the eye baseline)" +
            (lz->note.empty() ? std::string() : "; " + lz->note);
  result.Set(rz);
  for (int e = 0; e < 2; ++e) {
    Parameter pitch;
    pitch.name = std::string("head.") + models::kEyeNames[e] + ".mount_pitch_deg";
    pitch.value = 0;
    pitch.sigma = kNaN;
    pitch.unit = "deg";
    pitch.determined = false;
    pitch.note = "fixed at 0: a mount pitch is exactly a tilt offset, absorbed by the tilt servo's centre (gauge)";
    result.Set(pitch);
  }
  Parameter ipd;
  ipd.name = "head.ipd_mm";
  ipd.unit = "mm";
  ipd.value = head.geometry.Ipd() * 1000;
  const Eigen::Vector3d dv = head.geometry.centre_in_head[kRightEye] - head.geometry.centre_in_head[kLeftEye];
  // d ipd / d [lx ly lz rx ry] (m per m).
  const double g[5] = {-dv.x() / dv.norm(), -dv.y() / dv.norm(), 0, dv.x() / dv.norm(), dv.y() / dv.norm()};
  bool determined = true;
  std::string note;
  double var = 0;
  for (int a = 0; a < 5; ++a) {
    if (a == 2) continue;
    auto ia = tangent_of.find({&s.centres, a});
    const bool gauge_fixed = s.centres.fixed[a] && s.centres.fixed_note[a].find("gauge") != std::string::npos;
    if (ia == tangent_of.end()) {
      if (gauge_fixed) continue;  // a gauge choice does not change the IPD
      determined = false;
      note = "not determined: " + s.centres.names[a] + " " + s.centres.fixed_note[a];
      continue;
    }
    if (!cov.analysis.determined[ia->second]) {
      determined = false;
      note = "not determined: " + s.centres.names[a] + " " + cov.analysis.reasons[ia->second];
      continue;
    }
    for (int b = 0; b < 5; ++b) {
      auto ib = tangent_of.find({&s.centres, b});
      if (b == 2 || ib == tangent_of.end()) continue;
      var += g[a] * g[b] * cov_tangent(ia->second, ib->second);
    }
  }
  ipd.determined = determined;
  ipd.sigma = determined ? std::sqrt(std::max(var, 0.0)) * 1000 : kNaN;
  ipd.note = note;
  result.Set(ipd);
}

// The undetermined list, warnings grouped by reason, outliers, board poses and the options.
void ReportDiagnostics(const HeadFitOptions& options, size_t num_views_given, HeadFit* out) {
  HeadFit& fit = *out;
  CalibrationResult& result = fit.result;
  // Undetermined list and grouped warnings.
  std::map<std::string, std::vector<std::string>> by_note;
  for (const Parameter& p : result.parameters) {
    if (p.determined) continue;
    fit.undetermined.push_back(p.name + ": " + p.note);
    if (p.note.rfind("not determined", 0) == 0) by_note[p.note].push_back(p.name);
  }
  for (const auto& [note, names] : by_note) result.warnings.push_back(JoinNames(names) + " " + note);
  nlohmann::json outliers = nlohmann::json::array();
  for (size_t i = 0; i < fit.outliers.size() && i < 200; ++i) {
    const HeadOutlier& o = fit.outliers[i];
    outliers.push_back({{"frame", o.frame_index},
                        {"eye", models::kEyeNames[o.eye]},
                        {"target", o.target_id},
                        {"corner", o.corner_id},
                        {"error_px", std::isfinite(o.error_px) ? o.error_px : -1.0}});
  }
  result.diagnostics["head"]["outliers"] = outliers;
  nlohmann::json boards = nlohmann::json::object();
  for (const auto& [id, pose] : fit.base_from_target) {
    double a[7];
    pose.ToArray(a);
    boards[id] = std::vector<double>(a, a + 7);
  }
  result.diagnostics["head"]["base_from_target"] = boards;
  // Each noise class's whitening: the tags' and the chessboard's corners with their own sigma.
  nlohmann::json classes = nlohmann::json::object();
  for (const auto& [name, c] : fit.noise_classes)
    classes[name] = {
        {"whitening_sigma_px", c.sigma_px}, {"measured_sigma_px", c.measured_sigma_px}, {"num_corners", c.num_corners}};
  result.diagnostics["head"]["noise_classes"] = classes;
  result.inputs["head_fit"] = {
      {"corner_sigma_px", options.corner_sigma_px},
      {"estimate_corner_sigma", options.estimate_corner_sigma},
      {"measured_sigma_factor", options.measured_sigma_factor},
      {"min_corner_sigma_px", options.min_corner_sigma_px},
      {"hysteresis_sigma_floor_us", options.hysteresis_sigma_floor_us},
      {"covariance_clusters", options.covariance_clusters.Spec()},
      {"robust_sigma_factor", options.robust_sigma_factor},
      {"intrinsics_floor_carry", FloorCarryName(options.intrinsics_floor_carry)},
      {"pan_zero_sigma_factor", options.pan_zero_sigma_factor},
      {"view_outlier_factor", options.view_outlier_factor},
      {"noise_class_of_board", options.noise_class_of_board},
      {"tag_size_of_board", options.tag_size_of_board},
      {"sigma_factor_of_class", options.sigma_factor_of_class},
      {"whitening_sigma_px", {fit.corner_sigma_px[0], fit.corner_sigma_px[1]}},
      {"measured_corner_sigma_px", {fit.measured_corner_sigma_px[0], fit.measured_corner_sigma_px[1]}},
      {"fit_intrinsics", options.fit_intrinsics},
      {"fit_board_warp", options.fit_board_warp},
      {"fit_nonlinear", options.fit_nonlinear},
      {"fit_hysteresis", options.fit_hysteresis},
      {"huber_sigma", options.huber_sigma},
      {"outlier_threshold_sigma", options.outlier_threshold_sigma},
      {"num_views_given", num_views_given}};
}

}  // namespace

void WriteHeadOutputs(const models::HeadModel& initial,
                      const models::RobotConfig& robot,
                      const HeadFitOptions& options,
                      const HeadState& s,
                      const HeadCovariance& cov,
                      size_t num_views_given,
                      HeadFit* fit) {
  fit->head = HeadModelOf(s, initial, robot);
  fit->result.head = fit->head;
  for (const auto& [id, b] : s.boards) fit->base_from_target[id] = models::Rigid3d::Map(b.data());
  ReportBlockParameters(s, cov, options.fit_intrinsics, fit);
  ReportDerivedParameters(s, cov, fit->head, &fit->result);
  ReportDiagnostics(options, num_views_given, fit);
}

}  // namespace owlcal::fitting::internal
