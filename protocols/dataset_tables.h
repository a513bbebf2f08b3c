#pragma once
// Typed readers of a dataset's measurement tables (protocols/dataset.h lists them; their
// columns are in protocols/runner.h, whose steps write them with DatasetWriter::AppendRow).
// Everything downstream (calibrate, fit-datasets) reads the tables through these, never by
// splitting lines itself.
//
// Rules, the same for every table:
//  - DIR/<table> missing: no rows (the protocol had no such step).
//  - one row per record, in file order; `line` is the record's line in the file, for messages.
//  - a cut-short last record (a run killed while writing it) is dropped, as in frames.csv.
//  - cells are read by column name; a required column that is missing, a number that is not a
//    finite decimal within the column's range, or a status outside calib/trial_status.h throws
//    std::runtime_error naming "PATH:LINE: column NAME = '...' ...".
//  - columns newer than the first datasets (status, reason, approach_*) may be missing: the
//    field then keeps its "unknown" value (nullopt, 0). A measurement that was not made is an
//    empty cell; "nan", as earlier runners wrote it, reads the same (nullopt).
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/trial_status.h"
#include "models/robot_config.h"

namespace owlcal::protocols {

// fixations.csv: one row per fixation of a fixate step (vergence ranging).
struct FixationRow {
  int line = 0;
  int step_index = 0;
  std::string step_name;
  int placement_index = -1;  // row of placements.csv in force, -1 none
  std::string target;
  std::optional<double> distance_m;  // the placement's distance, if any
  std::string eyes;                  // both | left | right
  double gain = 0;
  std::string outcome;  // the loop's outcome: converged, target-lost, ...
  int iterations = 0;
  models::PwmVector pwm_us{};                               // the settled command
  std::array<bool, 2> found{};                              // left, right
  std::array<std::optional<Eigen::Vector2d>, 2> offset_px;  // target - image centre; nullopt if not measured
  int64_t stamp_ns = 0;
  std::array<int8_t, models::kNumServos> approach{};  // sign of each servo's last move, 0 unknown
  std::optional<calib::TrialStatus> status;           // nullopt: a dataset older than the column
  std::string reason;
  std::array<std::optional<double>, 2> radius_px;  // apparent target radius per eye
  std::optional<double> target_radius_m;           // the target's known radius
};
std::vector<FixationRow> ReadFixationsCsv(const std::string& dir);

// step_response.csv: one row per frame of a step-response trial.
struct StepResponseRow {
  int line = 0;
  int step_index = 0;
  double gain = 0;
  double amplitude_deg = 0;
  int trial = 0;
  int k = 0;                          // frame of the trial
  double t_s = 0;                     // from the trial's first frame
  std::optional<double> offset_px;    // along the stepped axis (x for pan, y for tilt)
  std::optional<double> offset_y_px;  // across it
  int pwm_us = 0;                     // the stepped servo's command
  bool found = false;
  int64_t frame_index = -1;  // -1: frame not recorded
};
std::vector<StepResponseRow> ReadStepResponseCsv(const std::string& dir);

// step_trials.csv: one row per step-response trial (a skipped one too).
struct StepTrialRow {
  int line = 0;
  int step_index = 0;
  double gain = 0;
  double amplitude_deg = 0;
  int trial = 0;
  std::string eye, axis, servo;
  std::string outcome;  // converged, no-fixation, target-lost, ...
  int frames = 0;
  std::optional<double> final_offset_px;
  std::string message;
  std::optional<calib::TrialStatus> status;  // nullopt: a dataset older than the column
  std::string reason;
};
std::vector<StepTrialRow> ReadStepTrialsCsv(const std::string& dir);

// limits.csv: one row per probed end of a servo.
struct LimitRow {
  int line = 0;
  int step_index = 0;
  std::string servo;  // Rx, Ry, Lx, Ly, Neck (as written; not checked here)
  std::string end;    // min | max
  int configured_us = 0;
  std::optional<int> measured_us;  // empty when the probe failed
  std::string cause;               // column "reason": end-stop | rim | configured
  std::optional<double> last_shift_px;
  std::optional<double> rim_darkening;
  // Signed image shift along the servo's axis per +1 us [px/us] (x right, y down; 0: nothing
  // moved); nullopt in datasets older than the column.
  std::optional<double> image_px_per_us;
  // At a rim end: what the search found beyond the rim with the rim ignored (beyond_rim_reason
  // end-stop or configured at beyond_rim_us; unknown: no motion measured past it; "": not
  // searched or an older dataset).
  std::optional<int> beyond_rim_us;
  std::string beyond_rim_reason;
  // Width of the servo's backlash band measured at this end (2 hysteresis_us of
  // models/servo_map.h) [us]; nullopt when not measured or in datasets older than the column.
  std::optional<double> backlash_us;
  std::optional<calib::TrialStatus> status;  // nullopt: a dataset older than the column
  std::string message;
};
std::vector<LimitRow> ReadLimitsCsv(const std::string& dir);

// resolution.csv: one row per command of a servo's fine resolution sweep (limits step).
struct ResolutionRow {
  int line = 0;
  int step_index = 0;
  std::string servo;  // Rx, Ry, Lx, Ly, Neck (as written; not checked here)
  int sample = 0;
  int command_us = 0;
  std::optional<double> position_px;  // empty: not measured (the command was still sent)
  std::optional<calib::TrialStatus> status;
  std::string reason;
};
std::vector<ResolutionRow> ReadResolutionCsv(const std::string& dir);

// latency.csv: one row per latency trial.
struct LatencyRow {
  int line = 0;
  int step_index = 0;
  int trial = 0;
  std::string servo;
  int amplitude_us = 0;
  std::optional<double> latency_ms;  // nullopt: no motion seen within the frames waited
  int frames_waited = 0;
  std::optional<double> shift_px;
  // Newer datasets (nullopt in older ones): the robot clock when the step was sent, the step's
  // pulse widths and the image shift that counted as motion.
  std::optional<int64_t> command_ns;
  std::optional<int> from_us, to_us;
  std::optional<double> threshold_px;
};
std::vector<LatencyRow> ReadLatencyCsv(const std::string& dir);

// alignment.csv: one row per frame of the alignment check (left minus right).
struct AlignmentRow {
  int line = 0;
  int step_index = 0;
  int64_t frame_index = 0;
  std::string method;              // chessboard | phase-correlation
  std::optional<double> roll_deg;  // nullopt: no chessboard in both eyes
  std::optional<double> vertical_offset_px;
  std::optional<double> horizontal_offset_px;
  int corners = 0;
};
std::vector<AlignmentRow> ReadAlignmentCsv(const std::string& dir);

}  // namespace owlcal::protocols
