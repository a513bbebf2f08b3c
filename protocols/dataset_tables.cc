#include "protocols/dataset_tables.h"

#include <filesystem>
#include <stdexcept>

#include "calib/csv.h"
#include "io/strict_number.h"
#include "protocols/dataset.h"

namespace owlcal::protocols {
namespace {

namespace fs = std::filesystem;

constexpr double kMaxPx = 1e5;
constexpr double kMaxGain = 1e3;
constexpr double kMaxDeg = 360;
constexpr int kMaxPwm = 9999;

// Row accessors of one table with the rules of dataset_tables.h.
class Rows {
 public:
  Rows(const std::string& dir, const char* name) : table_(ReadAppendedCsv((fs::path(dir) / name).string())) {}
  size_t Size() const { return table_.Header().empty() ? 0 : table_.NumRows(); }
  int Line(size_t r) const { return table_.Line(r); }
  bool Has(const char* column) const { return table_.HasColumn(column); }

  const std::string& Text(size_t r, const char* column) const { return table_.Text(r, column); }
  std::string TextOr(size_t r, const char* column) const { return Has(column) ? Text(r, column) : std::string(); }
  double Number(size_t r, const char* column, double min, double max) const {
    return table_.Number(r, column, min, max);
  }
  int Int(size_t r, const char* column, int min, int max) const { return table_.Int(r, column, min, max); }
  int64_t Int64(size_t r, const char* column) const { return table_.Integer(r, column, INT64_MIN, INT64_MAX); }
  // Empty (or "nan", as earlier runners wrote a measurement not made) -> nullopt.
  std::optional<double> Optional(size_t r, const char* column, double min, double max) const {
    const std::string& s = Text(r, column);
    if (s.empty() || s == "nan" || s == "-nan") return std::nullopt;
    return Number(r, column, min, max);
  }
  // The same for a column older datasets lack (nullopt there).
  std::optional<double> Newer(size_t r, const char* column, double min, double max) const {
    return Has(column) ? Optional(r, column, min, max) : std::nullopt;
  }
  std::optional<int> OptionalInt(size_t r, const char* column, int min, int max) const {
    if (Text(r, column).empty()) return std::nullopt;
    return Int(r, column, min, max);
  }
  bool Flag(size_t r, const char* column) const { return Int(r, column, 0, 1) == 1; }
  // nullopt when the column is missing (older datasets) or empty; an unknown name throws.
  std::optional<calib::TrialStatus> Status(size_t r) const {
    if (!Has("status")) return std::nullopt;
    const std::string& s = Text(r, "status");
    if (s.empty()) return std::nullopt;
    if (auto st = calib::TrialStatusFromName(s)) return st;
    throw std::runtime_error(table_.Where(r) + ": column status = '" + io::Printable(s) +
                             "' is not a trial status (ok, not settled, lost target, off target, timed out, skipped, "
                             "failed)");
  }

 private:
  calib::CsvTable table_;
};

// Every row of DIR/NAME as Row: its line and step_index, then fill(t, r, row) for the rest.
template <typename Row, typename Fill>
std::vector<Row> ReadDatasetTable(const std::string& dir, const char* name, Fill fill) {
  const Rows t(dir, name);
  std::vector<Row> out;
  out.reserve(t.Size());
  for (size_t r = 0; r < t.Size(); ++r) {
    Row row;
    row.line = t.Line(r);
    row.step_index = t.Int(r, "step_index", 0, INT32_MAX);
    fill(t, r, row);
    out.push_back(std::move(row));
  }
  return out;
}

// The columns naming a step-response trial: gain, amplitude_deg, trial.
template <typename Row>
void ReadTrialKey(const Rows& t, size_t r, Row& row) {
  row.gain = t.Number(r, "gain", -kMaxGain, kMaxGain);
  row.amplitude_deg = t.Number(r, "amplitude_deg", -kMaxDeg, kMaxDeg);
  row.trial = t.Int(r, "trial", 0, INT32_MAX);
}

}  // namespace

std::vector<FixationRow> ReadFixationsCsv(const std::string& dir) {
  return ReadDatasetTable<FixationRow>(dir, "fixations.csv", [](const Rows& t, size_t r, FixationRow& f) {
    f.step_name = t.Text(r, "step_name");
    f.placement_index = t.Int(r, "placement_index", -1, INT32_MAX);
    f.target = t.Text(r, "target");
    f.distance_m = t.Optional(r, "distance_m", 0, 1e3);
    f.eyes = t.Text(r, "eyes");
    f.gain = t.Number(r, "gain", -kMaxGain, kMaxGain);
    f.outcome = t.Text(r, "outcome");
    f.iterations = t.Int(r, "iterations", 0, INT32_MAX);
    for (int s = 0; s < models::kNumServos; ++s) {
      const std::string name = models::kServoNames[s];
      f.pwm_us[s] = t.Int(r, (name + "_us").c_str(), 0, kMaxPwm);
      const std::string approach = "approach_" + name;
      if (t.Has(approach.c_str())) f.approach[s] = static_cast<int8_t>(t.Int(r, approach.c_str(), -1, 1));
    }
    static const char* const kFound[2] = {"left_found", "right_found"};
    static const char* const kDx[2] = {"left_dx_px", "right_dx_px"};
    static const char* const kDy[2] = {"left_dy_px", "right_dy_px"};
    for (int e = 0; e < 2; ++e) {
      f.found[e] = t.Flag(r, kFound[e]);
      const auto dx = t.Optional(r, kDx[e], -kMaxPx, kMaxPx);
      const auto dy = t.Optional(r, kDy[e], -kMaxPx, kMaxPx);
      if (dx && dy) f.offset_px[e] = Eigen::Vector2d(*dx, *dy);
    }
    f.stamp_ns = t.Int64(r, "stamp_ns");
    f.status = t.Status(r);
    f.reason = t.TextOr(r, "reason");
    f.radius_px[0] = t.Newer(r, "left_radius_px", 0, kMaxPx);
    f.radius_px[1] = t.Newer(r, "right_radius_px", 0, kMaxPx);
    f.target_radius_m = t.Newer(r, "target_radius_m", 0, 1e3);
  });
}

std::vector<StepResponseRow> ReadStepResponseCsv(const std::string& dir) {
  return ReadDatasetTable<StepResponseRow>(dir, "step_response.csv", [](const Rows& t, size_t r, StepResponseRow& s) {
    ReadTrialKey(t, r, s);
    s.k = t.Int(r, "k", 0, INT32_MAX);
    s.t_s = t.Number(r, "t_s", -1e9, 1e9);
    s.offset_px = t.Optional(r, "offset_px", -kMaxPx, kMaxPx);
    s.offset_y_px = t.Optional(r, "offset_y_px", -kMaxPx, kMaxPx);
    s.pwm_us = t.Int(r, "pwm_us", 0, kMaxPwm);
    s.found = t.Flag(r, "found");
    s.frame_index = t.Int64(r, "frame_index");
  });
}

std::vector<StepTrialRow> ReadStepTrialsCsv(const std::string& dir) {
  return ReadDatasetTable<StepTrialRow>(dir, "step_trials.csv", [](const Rows& t, size_t r, StepTrialRow& s) {
    ReadTrialKey(t, r, s);
    s.eye = t.Text(r, "eye");
    s.axis = t.Text(r, "axis");
    s.servo = t.Text(r, "servo");
    s.outcome = t.Text(r, "outcome");
    s.frames = t.Int(r, "frames", 0, INT32_MAX);
    s.final_offset_px = t.Optional(r, "final_offset_px", -kMaxPx, kMaxPx);
    s.message = t.TextOr(r, "message");
    s.status = t.Status(r);
    s.reason = t.TextOr(r, "reason");
  });
}

std::vector<LimitRow> ReadLimitsCsv(const std::string& dir) {
  return ReadDatasetTable<LimitRow>(dir, "limits.csv", [](const Rows& t, size_t r, LimitRow& l) {
    l.servo = t.Text(r, "servo");
    l.end = t.Text(r, "end");
    l.configured_us = t.Int(r, "configured_us", 0, kMaxPwm);
    l.measured_us = t.OptionalInt(r, "measured_us", 0, kMaxPwm);
    l.cause = t.Text(r, "reason");
    l.last_shift_px = t.Newer(r, "last_shift_px", -kMaxPx, kMaxPx);
    l.rim_darkening = t.Newer(r, "rim_darkening", -1e3, 1e3);
    l.image_px_per_us = t.Newer(r, "image_px_per_us", -kMaxPx, kMaxPx);
    if (t.Has("beyond_rim_us")) l.beyond_rim_us = t.OptionalInt(r, "beyond_rim_us", 0, kMaxPwm);
    l.beyond_rim_reason = t.TextOr(r, "beyond_rim_reason");
    l.backlash_us = t.Newer(r, "backlash_us", -kMaxPwm, kMaxPwm);
    l.status = t.Status(r);
    l.message = t.TextOr(r, "message");
  });
}

std::vector<ResolutionRow> ReadResolutionCsv(const std::string& dir) {
  return ReadDatasetTable<ResolutionRow>(dir, "resolution.csv", [](const Rows& t, size_t r, ResolutionRow& x) {
    x.servo = t.Text(r, "servo");
    x.sample = t.Int(r, "sample", 0, INT32_MAX);
    x.command_us = t.Int(r, "command_us", 0, kMaxPwm);
    x.position_px = t.Optional(r, "position_px", -kMaxPx, kMaxPx);
    x.status = t.Status(r);
    x.reason = t.TextOr(r, "reason");
  });
}

std::vector<LatencyRow> ReadLatencyCsv(const std::string& dir) {
  return ReadDatasetTable<LatencyRow>(dir, "latency.csv", [](const Rows& t, size_t r, LatencyRow& l) {
    l.trial = t.Int(r, "trial", 0, INT32_MAX);
    l.servo = t.Text(r, "servo");
    l.amplitude_us = t.Int(r, "amplitude_us", -kMaxPwm, kMaxPwm);
    l.latency_ms = t.Optional(r, "latency_ms", 0, 1e7);
    l.frames_waited = t.Int(r, "frames_waited", 0, INT32_MAX);
    l.shift_px = t.Optional(r, "shift_px", -kMaxPx, kMaxPx);
    if (t.Has("command_ns")) l.command_ns = t.Int64(r, "command_ns");
    if (t.Has("from_us")) l.from_us = t.Int(r, "from_us", 0, kMaxPwm);
    if (t.Has("to_us")) l.to_us = t.Int(r, "to_us", 0, kMaxPwm);
    l.threshold_px = t.Newer(r, "threshold_px", 0, kMaxPx);
  });
}

std::vector<AlignmentRow> ReadAlignmentCsv(const std::string& dir) {
  return ReadDatasetTable<AlignmentRow>(dir, "alignment.csv", [](const Rows& t, size_t r, AlignmentRow& a) {
    a.frame_index = t.Int64(r, "frame_index");
    a.method = t.Text(r, "method");
    a.roll_deg = t.Optional(r, "roll_deg", -180, 180);
    a.vertical_offset_px = t.Optional(r, "vertical_offset_px", -kMaxPx, kMaxPx);
    a.horizontal_offset_px = t.Optional(r, "horizontal_offset_px", -kMaxPx, kMaxPx);
    a.corners = t.Int(r, "corners", 0, INT32_MAX);
  });
}

}  // namespace owlcal::protocols
