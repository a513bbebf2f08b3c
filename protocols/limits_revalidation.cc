#include "protocols/limits_revalidation.h"

#include <stdexcept>

#include "calib/csv.h"
#include "models/robot_config.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"

namespace owlcal::protocols {

bool RevalidationOptions::Check(std::string* why) const {
  if (servos.empty()) {
    *why = "re-validation: no servo to check";
    return false;
  }
  for (int s : servos)
    if (s < 0 || s >= models::kNumServos) {
      *why = "re-validation: no servo " + std::to_string(s);
      return false;
    }
  if (tolerance_us < 0 || tolerance_us > 100) {
    *why = "re-validation: tolerance_us " + std::to_string(tolerance_us) + " is outside 0..100";
    return false;
  }
  return true;
}

RunSummary SetUpLimitsScene(robot::RobotInterface& robot, const RunOptions& options) {
  Protocol setup = LoadProtocolFile(ResolveProtocolPath("limits"));
  std::vector<Step> steps;
  for (const Step& st : setup.steps) {
    if (st.kind() == StepKind::kLimits) break;
    steps.push_back(st);
  }
  setup.steps = steps;
  return RunProtocols({setup}, robot, options);
}

std::vector<ServoRevalidation> RevalidateLimits(robot::RobotInterface& robot,
                                                const std::string& out_dir,
                                                const RevalidationOptions& options) {
  std::string why;
  if (!options.Check(&why)) throw std::invalid_argument(why);
  Protocol p = LoadProtocolFile(ResolveProtocolPath("limits"));
  bool found = false;
  for (size_t i = 0; i < p.steps.size(); ++i)
    if (p.steps[i].kind() == StepKind::kLimits && p.steps[i].As<LimitsStep>().search_ends) {
      p.steps[i].As<LimitsStep>().servos = options.servos;
      p.steps.resize(i + 1);  // the ends only: the resolution probe after them is not needed here
      found = true;
      break;
    }
  if (!found) throw std::runtime_error(p.file + ": the limits protocol has no limits step");
  RunOptions ro;
  ro.out_dir = out_dir;
  ro.progress = options.progress;
  ro.robot_spec = robot.Describe();
  const RunSummary summary = RunProtocols({p}, robot, ro);
  const models::RobotConfig& config = robot.Config();
  std::vector<ServoRevalidation> out;
  for (int s : options.servos) {
    ServoRevalidation r;
    r.servo = s;
    r.limit_us[0] = config.servos[s].min_us;
    r.limit_us[1] = config.servos[s].max_us;
    r.cause[0] = r.cause[1] = "missing";
    out.push_back(r);
  }
  const std::string csv = out_dir + "/limits.csv";
  calib::CsvTable t = calib::CsvTable::Read(csv);
  for (size_t row = 0; row < t.NumRows(); ++row) {
    for (ServoRevalidation& r : out) {
      if (t.Text(row, "servo") != models::kServoNames[r.servo]) continue;
      const int e = t.Text(row, "end") == "max" ? 1 : 0;
      if (t.Text(row, "status") != "ok") {
        r.cause[e] = "failed: " + t.Text(row, "message");
        continue;
      }
      r.measured_us[e] = t.Int(row, "measured_us", 0, 9999);
      r.cause[e] = t.Text(row, "reason");
    }
  }
  for (ServoRevalidation& r : out) {
    std::string msg;
    for (int e = 0; e < 2; ++e) {
      const char* end = e ? "max" : "min";
      if (r.cause[e] == "missing" || r.cause[e].rfind("failed", 0) == 0) {
        msg += std::string(msg.empty() ? "" : "; ") + end + " not measured (" + r.cause[e] + ")";
        continue;
      }
      const int inside = e ? r.limit_us[1] - r.measured_us[1] : r.measured_us[0] - r.limit_us[0];
      if (inside > options.tolerance_us)
        msg += std::string(msg.empty() ? "" : "; ") + end + " " + r.cause[e] + " at " +
               std::to_string(r.measured_us[e]) + " us, " + std::to_string(inside) + " us inside the limit " +
               std::to_string(r.limit_us[e]);
    }
    r.pass = msg.empty();
    r.message = r.pass ? "both ends reached (within " + std::to_string(options.tolerance_us) + " us)" : msg;
  }
  if (summary.status != "complete" && options.progress)
    *options.progress << "limits protocol: " << summary.status << ": " << summary.message << "\n";
  return out;
}

}  // namespace owlcal::protocols
