#include "fitting/robot_file_check.h"
#include "io/number_text.h"

#include <cmath>
#include <sstream>

namespace owlcal::fitting {
namespace {

std::string SignificantNum(double v, int significant) { return io::SignificantText(v, significant); }

// The fitted parameter, when it says something: present, determined, finite, with a finite sigma.
const Parameter* Usable(const CalibrationResult& r, const std::string& name) {
  const Parameter* p = r.Find(name);
  if (p == nullptr || !p->determined || !std::isfinite(p->value) || !std::isfinite(p->sigma)) return nullptr;
  return p;
}

}  // namespace

bool RobotFileTolerance::Check(std::string* why) const {
  auto bad = [&](const char* m) {
    if (why) *why = m;
    return false;
  };
  for (double v : {ipd_mm, centre_us, scale_fraction, n_sigma})
    if (!(v > 0) || !std::isfinite(v)) return bad("robot-file tolerances must be positive and finite");
  return true;
}

std::vector<RobotFileDisagreement> CompareWithRobotFile(const CalibrationResult& fitted,
                                                        const models::RobotConfig& robot,
                                                        const RobotFileTolerance& tol) {
  std::vector<RobotFileDisagreement> out;
  // Beyond n sigma of the fit and beyond the physical tolerance.
  auto far = [&](double fit, double sigma, double file, double tolerance) {
    const double d = std::abs(fit - file);
    return d > tol.n_sigma * sigma && d > tolerance;
  };
  auto add = [&](const std::string& servo,
                 const std::string& kind,
                 const Parameter& p,
                 double file,
                 const std::string& unit,
                 const std::string& detail,
                 const std::string& fix) {
    RobotFileDisagreement d{servo.empty() ? kind : servo + " " + kind, p.name, p.value, p.sigma, file, unit, "", ""};
    const double z = p.sigma > 0 ? (p.value - file) / p.sigma : INFINITY;
    d.item = (servo.empty() ? kind : servo) + " " + SignificantNum(p.value, 6) + " \u00b1 " +
             SignificantNum(p.sigma, 2) + " " + unit + ", file " + SignificantNum(file, 6) + " " + unit + " (" +
             detail + ", " + SignificantNum(std::abs(z), 3) + "\u03c3)";
    d.message = (servo.empty() ? "" : servo + " ") + kind + " " + SignificantNum(p.value, 6) + " \u00b1 " +
                SignificantNum(p.sigma, 2) + " " + unit + ", robot file says " + SignificantNum(file, 6) + " " + unit +
                " (" + detail + ", " + SignificantNum(std::abs(z), 3) + "\u03c3): " + fix;
    out.push_back(std::move(d));
  };

  if (const Parameter* p = Usable(fitted, "head.ipd_mm")) {
    const double file = robot.ipd_m * 1000;
    if (far(p->value, p->sigma, file, tol.ipd_mm))
      add("",
          "IPD",
          *p,
          file,
          "mm",
          SignificantNum(100 * std::abs(p->value - file) / p->value, 2) + " % of every nominal range",
          "update ipd_mm in the robot file");
  }
  for (int i = 0; i < models::kNumServos; ++i) {
    const models::ServoConfig& sc = robot.servos[i];
    const std::string name = models::kServoNames[i];
    if (const Parameter* p = Usable(fitted, "servo." + name + ".centre_us")) {
      if (far(p->value, p->sigma, sc.centre_us, tol.centre_us))
        add(name,
            "centre",
            *p,
            sc.centre_us,
            "\u00b5s",
            SignificantNum(std::abs(p->value - sc.centre_us) * sc.nominal_deg_per_us, 2) + "\u00b0 off straight ahead",
            "update centre_us in the robot file");
    }
    if (const Parameter* p = Usable(fitted, "servo." + name + ".deg_per_us")) {
      if (p->value < 0 && std::abs(p->value) > tol.n_sigma * p->sigma) {
        RobotFileDisagreement d{name + " direction", p->name, p->value, p->sigma, double(sc.direction), "", "", ""};
        d.item = name + " turns the other way from the file's direction " + std::to_string(sc.direction) +
                 " (fitted deg/\u00b5s " + SignificantNum(p->value, 4) + " \u00b1 " + SignificantNum(p->sigma, 2) +
                 "): set direction: " + std::to_string(-sc.direction);
        d.message = d.item + " in the robot file";
        out.push_back(std::move(d));
      } else if (far(p->value, p->sigma, sc.nominal_deg_per_us, tol.scale_fraction * sc.nominal_deg_per_us)) {
        add(name,
            "scale",
            *p,
            sc.nominal_deg_per_us,
            "deg/\u00b5s",
            SignificantNum(100 * (p->value / sc.nominal_deg_per_us - 1), 2) + " %",
            "update deg_per_us in the robot file");
      }
    }
  }
  return out;
}

std::vector<std::string> RobotFileWarnings(const std::vector<RobotFileDisagreement>& disagreements) {
  static const char* kGroups[3] = {"the IPD; update ipd_mm",
                                   "servo centres; update centre_us",
                                   "servo scales and directions; update deg_per_us or direction"};
  std::vector<std::string> lines(3);
  for (const auto& d : disagreements) {
    const int g = d.what == "IPD" ? 0 : d.what.find(" centre") != std::string::npos ? 1 : 2;
    lines[g] += (lines[g].empty() ? "" : "; ") + d.item;
  }
  std::vector<std::string> out;
  for (int g = 0; g < 3; ++g)
    if (!lines[g].empty())
      out.push_back(std::string("robot file disagrees with the fit (") + kGroups[g] + "): " + lines[g]);
  return out;
}

}  // namespace owlcal::fitting
