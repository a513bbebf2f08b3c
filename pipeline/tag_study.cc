#include "pipeline/tag_study.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "evaluation/servo_map_eval.h"
#include "fitting/board_warp.h"
#include "io/json_strict.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"

namespace owlcal::pipeline {
namespace {

constexpr const char* kTagClass = "apriltag";

std::string ClassOf(const calib::View& v, const std::map<std::string, std::string>& classes) {
  const auto it = classes.find(fitting::BoardOfTarget(v.target_id));
  return it == classes.end() ? std::string(fitting::kDefaultNoiseClass) : it->second;
}

// The fit as a result SampleServoMap reads: head, parameters and their joint covariance.
fitting::CalibrationResult ResultOf(const fitting::HeadFit& h) {
  fitting::CalibrationResult r = h.result;
  r.head = h.head;
  if (const nlohmann::json c = HeadCovarianceJson(h); !c.is_null()) r.diagnostics["covariance"] = c;
  return r;
}

}  // namespace

std::map<std::string, std::string> NoiseClassesOfDataset(const std::string& dataset) {
  std::map<std::string, std::string> out;
  for (const auto& [name, def] : protocols::TargetsOfDataset(dataset)) {
    if (def.kind == calib::TargetKind::kAprilGrid) out[name] = kTagClass;
    if (def.kind == calib::TargetKind::kChessboard) out[name] = "chessboard";
  }
  return out;
}

std::map<std::string, double> TagSizesOfDataset(const std::string& dataset) {
  std::map<std::string, double> out;
  for (const auto& [name, def] : protocols::TargetsOfDataset(dataset))
    if (def.kind == calib::TargetKind::kAprilGrid) out[name] = def.tag_size_m;
  return out;
}

nlohmann::json HeadCovarianceJson(const fitting::HeadFit& h) {
  if (h.covariance.rows() == int(h.param_names.size()) && !h.param_names.empty()) {
    nlohmann::json m = nlohmann::json::array();
    for (int i = 0; i < h.covariance.rows(); ++i) {
      std::vector<double> row(h.covariance.cols());
      for (int j = 0; j < h.covariance.cols(); ++j)
        row[j] = std::isfinite(h.covariance(i, j)) ? h.covariance(i, j) : 0.0;
      m.push_back(row);
    }
    return {{"names", h.param_names}, {"matrix", m}};
  }
  return nullptr;
}

std::vector<calib::View> WithoutTags(const std::vector<calib::View>& views,
                                     const std::map<std::string, std::string>& noise_class_of_board) {
  std::vector<calib::View> out;
  for (const calib::View& v : views)
    if (ClassOf(v, noise_class_of_board) != kTagClass) out.push_back(v);
  return out;
}

nlohmann::json TagStudy(const std::vector<calib::View>& views,
                        const std::map<std::string, std::string>& noise_class_of_board,
                        const fitting::HeadFit& with_tags,
                        const std::optional<fitting::HeadFit>& without,
                        const models::RobotConfig& config,
                        const models::HeadModel* truth) {
  nlohmann::json out;
  // Coverage: the views of each class, and per servo the pulse widths each class saw.
  nlohmann::json classes = nlohmann::json::object();
  std::map<std::string, std::array<std::array<int, 2>, models::kNumServos>> range;  // class -> servo -> min, max
  std::map<std::string, std::array<int, 2>> num_views;
  for (const calib::View& v : views) {
    const std::string c = ClassOf(v, noise_class_of_board);
    if (!range.count(c)) {
      for (auto& r : range[c]) r = {std::numeric_limits<int>::max(), std::numeric_limits<int>::min()};
      num_views[c] = {0, 0};
    }
    ++num_views[c][v.eye == models::kLeftEye ? 0 : 1];
    for (int s = 0; s < models::kNumServos; ++s) {
      // An eye's views say nothing about the other eye's servos.
      const bool other_eye =
          (s == models::kRx || s == models::kRy) != (v.eye == models::kRightEye) && s != models::kNeck;
      if (other_eye) continue;
      range[c][s][0] = std::min(range[c][s][0], v.pwm_us[s]);
      range[c][s][1] = std::max(range[c][s][1], v.pwm_us[s]);
    }
  }
  for (const auto& [c, r] : range) {
    nlohmann::json servos = nlohmann::json::object();
    for (int s = 0; s < models::kNumServos; ++s)
      if (r[s][0] <= r[s][1]) servos[models::kServoNames[s]] = {r[s][0], r[s][1]};
    nlohmann::json cls = {{"views", num_views[c]}, {"pwm_us", servos}};
    if (const auto it = with_tags.noise_classes.find(c); it != with_tags.noise_classes.end()) {
      cls["corners"] = it->second.num_corners;
      cls["whitening_sigma_px"] = it->second.sigma_px;
      cls["measured_sigma_px"] = it->second.measured_sigma_px;
    }
    classes[c] = cls;
  }
  out["classes"] = classes;

  // Each servo map's sigma (and error, with truth) at both ends of its configured range.
  const fitting::CalibrationResult with_result = ResultOf(with_tags);
  std::optional<fitting::CalibrationResult> without_result;
  if (without) without_result = ResultOf(*without);
  nlohmann::json ends = nlohmann::json::array();
  for (int s = 0; s < models::kNumServos; ++s) {
    const auto a = evaluation::SampleServoMap(with_result, config.servos[s], s, truth, 1);
    std::vector<evaluation::ServoMapSample> b;
    if (without_result) b = evaluation::SampleServoMap(*without_result, config.servos[s], s, truth, 1);
    for (size_t k = 0; k < a.size(); ++k) {
      nlohmann::json e = {{"servo", models::kServoNames[s]},
                          {"end", k == 0 ? "min" : "max"},
                          {"pwm_us", a[k].pwm_us},
                          {"sigma_with_tags_deg", io::JsonNumber(a[k].sigma_deg)},
                          {"sigma_without_tags_deg", nullptr},
                          {"error_with_tags_deg", nullptr},
                          {"error_without_tags_deg", nullptr}};
      if (k < b.size()) e["sigma_without_tags_deg"] = io::JsonNumber(b[k].sigma_deg);
      if (truth) {
        e["error_with_tags_deg"] = io::JsonNumber(a[k].angle_deg - a[k].truth_deg);
        if (k < b.size()) e["error_without_tags_deg"] = io::JsonNumber(b[k].angle_deg - b[k].truth_deg);
      }
      ends.push_back(e);
    }
  }
  out["servo_ends"] = ends;
  out["without_tags_fit"] = without ? (without->ok ? "ok" : "failed: " + without->message) : "not run";
  return out;
}

}  // namespace owlcal::pipeline
