#include "pipeline/bring_up.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <fstream>
#include <optional>

#include "calib/trial_status.h"
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::pipeline {
namespace {

std::string Signed(int d) { return d > 0 ? "+1" : "-1"; }

// The image-shift sign a servo of direction +1 gives per +1 us with the file's stream layout:
// x-axis servos (pans, neck) move the scene left (-1), tilts move it down (+1).
int ImageSignOfPositiveDirection(int servo) { return protocols::ServoAxis(servo) == 0 ? -1 : +1; }

}  // namespace

bool BringUp::Changed() const {
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig &a = file.servos[s], &b = learned.servos[s];
    if (a.min_us != b.min_us || a.max_us != b.max_us || a.centre_us != b.centre_us || a.direction != b.direction)
      return true;
  }
  return file.mirror_stream != learned.mirror_stream || file.swap_eyes != learned.swap_eyes;
}

nlohmann::json BringUp::ToJson() const {
  nlohmann::json servos = nlohmann::json::array();
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig &a = file.servos[s], &b = learned.servos[s];
    servos.push_back(
        {{"servo", models::kServoNames[s]},
         {"file", {{"min_us", a.min_us}, {"max_us", a.max_us}, {"centre_us", a.centre_us}, {"direction", a.direction}}},
         {"used",
          {{"min_us", b.min_us}, {"max_us", b.max_us}, {"centre_us", b.centre_us}, {"direction", b.direction}}}});
  }
  return {{"changed", Changed()},
          {"findings", findings},
          {"notes", notes},
          {"robot_time_s", robot_time_s},
          {"servos", servos},
          {"source", "the limits protocol's image motion (limits.csv)"}};
}

std::vector<evaluation::LimitMeasurement> LimitMeasurements(const std::vector<protocols::LimitRow>& rows,
                                                            std::vector<std::string>* failed,
                                                            int* num_rows) {
  std::vector<evaluation::LimitMeasurement> out;
  *num_rows = int(rows.size());
  for (const protocols::LimitRow& row : rows) {
    const std::string what = row.servo + " " + row.end + " (limits.csv line " + std::to_string(row.line) + ")";
    const int s = protocols::ServoIndexFromName(row.servo);
    evaluation::LimitMeasurement m;
    m.servo = s;
    m.high_end = row.end == "max";
    m.cause = evaluation::LimitCauseFromName(row.cause);
    if (s < 0 || (row.status && *row.status != calib::TrialStatus::kOk) || !row.measured_us) {
      failed->push_back(what + ": " + (row.status ? calib::TrialStatusName(*row.status) : "no measurement") +
                        (row.message.empty() ? "" : ": " + row.message));
      continue;
    }
    m.measured_us = *row.measured_us;
    out.push_back(m);
  }
  return out;
}

BringUp LearnFromLimits(const models::RobotConfig& file,
                        const std::vector<protocols::LimitRow>& rows,
                        int margin_us,
                        int stop_error_us,
                        int grid_us) {
  BringUp b;
  b.file = file;
  b.learned = file;

  // Direction: the sign of the image motion at both ends of each servo.
  std::array<int, models::kNumServos> seen{};  // +1 / -1: the image sign both ends agree on; 0: none
  for (int s = 0; s < models::kNumServos; ++s) {
    int pos = 0, neg = 0;
    for (const auto& r : rows) {
      if (protocols::ServoIndexFromName(r.servo) != s || !r.image_px_per_us) continue;
      if (r.status && *r.status != calib::TrialStatus::kOk) continue;
      pos += *r.image_px_per_us > 0;
      neg += *r.image_px_per_us < 0;
    }
    if (pos > 0 && neg == 0) seen[s] = +1;
    if (neg > 0 && pos == 0) seen[s] = -1;
    if (pos > 0 && neg > 0)
      b.notes.push_back(std::string(models::kServoNames[s]) +
                        ": the image moved one way at one end and the other way at the other; direction kept");
  }
  std::array<bool, models::kNumServos> reversed{};
  for (int s = 0; s < models::kNumServos; ++s)
    reversed[s] = seen[s] != 0 && seen[s] != ImageSignOfPositiveDirection(s) * file.servos[s].direction;
  const bool x_all = reversed[models::kRx] && reversed[models::kLx] && reversed[models::kNeck];
  const bool tilts_agree =
      seen[models::kRy] != 0 && seen[models::kLy] != 0 && !reversed[models::kRy] && !reversed[models::kLy];
  if (x_all && tilts_agree) {
    b.findings.push_back(
        std::string("the image moves the other way from the robot file for Rx, Lx and the neck while both tilts agree: "
                    "the stream is mirrored against the robot file (image.mirror is ") +
        (file.mirror_stream ? "true" : "false") +
        "); directions kept, fix image.mirror in the robot file (the stereo fit's T_x sign says the same)");
  } else {
    for (int s = 0; s < models::kNumServos; ++s) {
      if (!reversed[s]) continue;
      const int turns = -file.servos[s].direction;
      b.learned.servos[s].direction = turns;
      b.findings.push_back("your robot file says " + Signed(file.servos[s].direction) + " for " +
                           models::kServoNames[s] + "; the robot turns " + Signed(turns) + "; used " + Signed(turns));
    }
  }
  for (int s = 0; s < models::kNumServos; ++s)
    if (seen[s] == 0)
      b.notes.push_back(std::string(models::kServoNames[s]) + ": direction not measured (no end's image moved); " +
                        Signed(file.servos[s].direction) + " from the robot file used");

  // Limits: the measured end-stops minus the margin and the search's error. The socket rim is
  // where the image stops being whole, not where the servo must stop: it is noted, and the
  // sweep's tag sheets carry the fit there.
  std::vector<std::string> failed;
  int num_rows = 0;
  const std::vector<evaluation::LimitMeasurement> measured = LimitMeasurements(rows, &failed, &num_rows);
  const evaluation::LimitsEvaluation ev = evaluation::EvaluateLimits(file, measured, nullptr, margin_us, stop_error_us);
  for (const evaluation::ServoLimits& l : ev.servos) {
    models::ServoConfig& c = b.learned.servos[l.servo];
    int lo = c.min_us, hi = c.max_us;
    auto bound = [&](const char* end, std::optional<double> at, evaluation::LimitCause cause, int* us, int inward) {
      if (!at) return;
      if (cause == evaluation::LimitCause::kSocketRim) {
        // The search went on past the rim with the rim ignored (limits.csv beyond_rim_*).
        const protocols::LimitRow* row = nullptr;
        for (const auto& r : rows)
          if (protocols::ServoIndexFromName(r.servo) == l.servo && (r.end == "min") == (inward > 0)) row = &r;
        const std::string rim = l.name + " " + end + ": the socket rim enters the image at " +
                                std::to_string(int(std::lround(*at))) + " us";
        if (row && row->beyond_rim_reason == "end-stop" && row->beyond_rim_us) {
          b.notes.push_back(rim + "; the end-stop behind it is at " + std::to_string(*row->beyond_rim_us) + " us");
          at = double(*row->beyond_rim_us);
          cause = evaluation::LimitCause::kEndStop;
        } else if (row && row->beyond_rim_reason == "unknown") {
          // Nothing measured past the rim: the stop may be anywhere there.
          b.notes.push_back(rim + "; nothing was measured past it, so commands stop at the rim");
          cause = evaluation::LimitCause::kEndStop;
        } else {
          b.notes.push_back(rim + (row && row->beyond_rim_reason == "configured"
                                       ? "; the image follows past it to the configured limit"
                                       : "; an end-stop beyond it was not searched (the robot file's limit kept)"));
          return;
        }
      }
      if (cause != evaluation::LimitCause::kEndStop) return;
      int safe = inward > 0 ? int(std::ceil(*at)) + margin_us + stop_error_us
                            : int(std::floor(*at)) - margin_us - stop_error_us;
      // Rounded inward to pigpio's 5 us grid: poses the protocols derive from a limit (servo_sweep's
      // min+30) are then pulses a 5 us servo applies as commanded, not rounded by up to 2.5 us.
      const int g = std::max(1, grid_us);
      safe = inward > 0 ? (safe + g - 1) / g * g : safe / g * g;
      if ((safe - *us) * inward <= 0) return;  // the file's limit is already inside it
      const int stop = int(std::lround(*at));
      b.findings.push_back(l.name + " " + end + " limit: your robot file says " + std::to_string(*us) +
                           " us; end-stop measured at " + std::to_string(stop) + " us; used " + std::to_string(safe) +
                           " us (" + std::to_string(std::abs(safe - stop)) + " us inside)");
      *us = safe;
    };
    bound("low", l.measured_min_us, l.min_cause, &lo, +1);
    bound("high", l.measured_max_us, l.max_cause, &hi, -1);
    if (lo >= hi) {
      b.notes.push_back(l.name + ": no usable range left inside the measured end-stops; the robot file's range kept");
      continue;
    }
    c.min_us = lo;
    c.max_us = hi;
    const int centre = std::clamp(c.centre_us, c.min_us, c.max_us);
    if (centre != c.centre_us) {
      b.findings.push_back(l.name + " centre: your robot file's " + std::to_string(c.centre_us) +
                           " us is outside the measured range; used " + std::to_string(centre) + " us");
      c.centre_us = centre;
    }
  }
  for (const auto& f : failed) b.notes.push_back("not measured: " + f);
  return b;
}

models::RobotConfig CorrectedRobotFile(const models::RobotConfig& file,
                                       const models::RobotConfig& used,
                                       const fitting::CalibrationResult& result,
                                       std::vector<std::string>* changes) {
  models::RobotConfig c = used;
  auto usable = [&](const std::string& name) -> const fitting::Parameter* {
    const fitting::Parameter* p = result.Find(name);
    return p && p->determined && std::isfinite(p->value) ? p : nullptr;
  };
  for (int s = 0; s < models::kNumServos; ++s) {
    models::ServoConfig& sc = c.servos[s];
    const std::string name = models::kServoNames[s];
    if (const fitting::Parameter* p = usable("servo." + name + ".centre_us"))
      sc.centre_us = std::clamp(int(std::lround(p->value)), sc.min_us, sc.max_us);
    // The fitted map's scale is signed in the used direction's convention.
    if (const fitting::Parameter* p = usable("servo." + name + ".deg_per_us"); p && p->value != 0) {
      if (p->value < 0) sc.direction = -sc.direction;
      sc.nominal_deg_per_us = std::round(std::abs(p->value) * 1e4) / 1e4;
    }
  }
  if (const fitting::Parameter* p = usable("head.ipd_mm")) c.ipd_m = std::round(p->value * 10) / 1e4;
  const auto line = [&](const std::string& what, const std::string& was, const std::string& now) {
    if (was != now) changes->push_back(what + ": " + was + " -> " + now);
  };
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig &a = file.servos[s], &b = c.servos[s];
    const std::string n = models::kServoNames[s];
    line(n + " min_us", std::to_string(a.min_us), std::to_string(b.min_us));
    line(n + " max_us", std::to_string(a.max_us), std::to_string(b.max_us));
    line(n + " centre_us", std::to_string(a.centre_us), std::to_string(b.centre_us));
    line(n + " direction", std::to_string(a.direction), std::to_string(b.direction));
  }
  line("ipd_m", std::to_string(file.ipd_m), std::to_string(c.ipd_m));
  return c;
}

double RobotTimeOfDataset(const std::string& dataset) {
  std::ifstream in(dataset + "/events.log");
  int64_t first = 0, last = 0;
  bool any = false;
  for (std::string line; std::getline(in, line);) {
    const size_t tab = line.find('\t');
    if (tab == std::string::npos || tab == 0) continue;
    int64_t stamp = 0;
    const auto [end, ec] = std::from_chars(line.data(), line.data() + tab, stamp);
    if (ec != std::errc() || end != line.data() + tab) continue;
    if (!any) first = stamp;
    first = std::min(first, stamp);
    last = std::max(last, stamp);
    any = true;
  }
  return any ? (last - first) * 1e-9 : 0.0;
}

BringUp LearnFromLimitsDataset(const models::RobotConfig& file, const std::string& dataset, int grid_us) {
  BringUp b = LearnFromLimits(file, protocols::ReadLimitsCsv(dataset), 10, 5, grid_us);
  b.robot_time_s = RobotTimeOfDataset(dataset);
  return b;
}

}  // namespace owlcal::pipeline
