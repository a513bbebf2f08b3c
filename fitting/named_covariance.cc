#include "fitting/named_covariance.h"

#include <cmath>
#include <map>
#include <optional>

namespace owlcal::fitting {
namespace {

struct ParamSlot {
  int servo = -1;  // servo param index when >= 0
  int index = 0;
  int eye = -1;  // intrinsics when >= 0
  bool ipd = false;
};

std::optional<ParamSlot> Slot(const std::string& name) {
  static const std::map<std::string, int> kServoFields = {
      {"centre_us", 0}, {"deg_per_us", 1}, {"quad_deg", 2}, {"cubic_deg", 3}, {"hysteresis_us", 4}};
  static const std::map<std::string, int> kCamFields = {{"fx", 0}, {"fy", 1}, {"cx", 2}, {"cy", 3}};
  if (name == "head.ipd_mm") return ParamSlot{-1, 0, -1, true};
  const auto dot1 = name.find('.');
  if (dot1 == std::string::npos) return std::nullopt;
  const std::string head = name.substr(0, dot1);
  if (head == "servo") {
    const auto dot2 = name.find('.', dot1 + 1);
    if (dot2 == std::string::npos) return std::nullopt;
    const std::string servo = name.substr(dot1 + 1, dot2 - dot1 - 1);
    const std::string field = name.substr(dot2 + 1);
    for (int i = 0; i < models::kNumServos; ++i) {
      if (servo == models::kServoNames[i] && kServoFields.count(field))
        return ParamSlot{i, kServoFields.at(field), -1, false};
    }
    return std::nullopt;
  }
  for (int e = 0; e < 2; ++e) {
    if (head == models::kEyeNames[e]) {
      const std::string field = name.substr(dot1 + 1);
      if (kCamFields.count(field)) return ParamSlot{-1, kCamFields.at(field), e, false};
    }
  }
  return std::nullopt;
}

}  // namespace

NamedCovariance CovarianceFromResult(const CalibrationResult& result, const std::vector<std::string>& wanted) {
  NamedCovariance c;
  for (const std::string& n : wanted) {
    const Parameter* p = result.Find(n);
    if (p && p->determined && std::isfinite(p->sigma) && p->sigma > 0) c.names.push_back(n);
  }
  const int n = int(c.names.size());
  c.matrix = Eigen::MatrixXd::Zero(n, n);
  std::vector<int> full_index(n, -1);
  const nlohmann::json& d = result.diagnostics;
  bool have_full = false;
  if (d.is_object() && d.contains("covariance") && d["covariance"].contains("names") &&
      d["covariance"].contains("matrix")) {
    const auto names = d["covariance"]["names"].get<std::vector<std::string>>();
    const auto& m = d["covariance"]["matrix"];
    for (int i = 0; i < n; ++i)
      for (size_t k = 0; k < names.size(); ++k)
        if (names[k] == c.names[i]) full_index[i] = int(k);
    for (int i = 0; i < n; ++i) {
      for (int j = 0; j < n; ++j) {
        if (full_index[i] >= 0 && full_index[j] >= 0) {
          const auto& v = m.at(full_index[i]).at(full_index[j]);
          if (v.is_number()) c.matrix(i, j) = v.get<double>();
          have_full = true;
        }
      }
    }
  }
  for (int i = 0; i < n; ++i)
    if (!have_full || full_index[i] < 0) c.matrix(i, i) = std::pow(result.Find(c.names[i])->sigma, 2);
  return c;
}

bool PerturbHead(const std::string& name, double delta, models::HeadModel* head) {
  const auto s = Slot(name);
  if (!s) return false;
  if (s->ipd) {
    Eigen::Vector3d& l = head->geometry.centre_in_head[models::kLeftEye];
    Eigen::Vector3d& r = head->geometry.centre_in_head[models::kRightEye];
    const Eigen::Vector3d u = (r - l).normalized();
    l -= u * (delta * 5e-4);
    r += u * (delta * 5e-4);
  } else if (s->servo >= 0) {
    head->servo_params[s->servo][s->index] += delta;
  } else {
    head->intrinsics[s->eye].params[s->index] += delta;
  }
  return true;
}

}  // namespace owlcal::fitting
