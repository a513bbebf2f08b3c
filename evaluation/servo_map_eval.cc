#include "evaluation/servo_map_eval.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Core>

#include "evaluation/ranging_eval.h"
#include "models/servo_map.h"
#include "models/units.h"

namespace owlcal::evaluation {
namespace {

// Statistics of fitted_rad(u) - truth_rad(u) [deg] over n equally spaced samples.
template <typename Fitted, typename Truth>
ServoMapError ErrorOverRange(Fitted fitted_rad, Truth truth_rad, double lo_us, double hi_us, int num_samples) {
  ServoMapError e;
  const int n = std::max(2, num_samples);
  double sum = 0, sum2 = 0;
  for (int i = 0; i < n; ++i) {
    const double u = lo_us + (hi_us - lo_us) * i / (n - 1.0);
    const double d = (fitted_rad(u) - truth_rad(u)) * kRadToDeg;
    sum += d;
    sum2 += d * d;
    e.max_abs_deg = std::max(e.max_abs_deg, std::abs(d));
  }
  e.rms_deg = std::sqrt(sum2 / n);
  e.mean_deg = sum / n;
  return e;
}

}  // namespace

std::vector<ServoMapSample> SampleServoMap(const fitting::CalibrationResult& result,
                                           const models::ServoConfig& config,
                                           int servo,
                                           const models::HeadModel* truth,
                                           int num_intervals) {
  std::vector<ServoMapSample> out;
  if (!result.head || num_intervals < 1) return out;
  const models::HeadModel& h = *result.head;
  const std::string prefix = std::string("servo.") + models::kServoNames[servo] + ".";
  std::vector<std::string> names;
  for (const char* f : {"centre_us", "deg_per_us", "quad_deg", "cubic_deg"}) {
    const fitting::Parameter* p = result.Find(prefix + f);
    if (p && p->determined) names.push_back(prefix + f);
  }
  const fitting::NamedCovariance cov = fitting::CovarianceFromResult(result, names);
  for (int i = 0; i <= num_intervals; ++i) {
    ServoMapSample s;
    s.pwm_us = config.min_us + (config.max_us - config.min_us) * double(i) / num_intervals;
    const double a = h.ServoAngle(servo, s.pwm_us);
    s.angle_deg = a * kRadToDeg;
    s.nominal_deg = config.direction * config.nominal_deg_per_us * (s.pwm_us - config.centre_us);
    // Gradient of the angle with respect to the named parameters (forward differences in the
    // parameters' result units), then g C g^T.
    Eigen::RowVectorXd g = Eigen::RowVectorXd::Zero(cov.names.size());
    for (size_t k = 0; k < cov.names.size(); ++k) {
      models::HeadModel hp = h;
      const double step = cov.names[k].find("deg_per_us") != std::string::npos ? 1e-5 : 1e-3;
      fitting::PerturbHead(cov.names[k], step, &hp);
      g[k] = (hp.ServoAngle(servo, s.pwm_us) - a) * kRadToDeg / step;
    }
    s.sigma_deg = cov.names.empty() ? 0.0 : std::sqrt(std::max(0.0, (g * cov.matrix * g.transpose())(0, 0)));
    if (truth) s.truth_deg = truth->ServoAngle(servo, s.pwm_us) * kRadToDeg;
    out.push_back(s);
  }
  return out;
}

ServoMapError ServoMapErrorOverRange(const models::HeadModel& fitted,
                                     const models::HeadModel& truth,
                                     int servo,
                                     double lo_us,
                                     double hi_us,
                                     int num_samples) {
  return ErrorOverRange([&](double u) { return fitted.ServoAngle(servo, u); },
                        [&](double u) { return truth.ServoAngle(servo, u); },
                        lo_us,
                        hi_us,
                        num_samples);
}

ServoMapError ServoMapErrorOverRange(
    const double* fitted, const double* truth, int direction, double lo_us, double hi_us, int num_samples) {
  return ErrorOverRange([&](double u) { return models::ServoMap::JointAngle(fitted, direction, u, 0); },
                        [&](double u) { return models::ServoMap::JointAngle(truth, direction, u, 0); },
                        lo_us,
                        hi_us,
                        num_samples);
}

double ServoMapRmsDeg(const double* a, const double* b, int direction, double lo_us, double hi_us) {
  return ServoMapErrorOverRange(a, b, direction, lo_us, hi_us, 201).rms_deg;
}

}  // namespace owlcal::evaluation
