#pragma once
// What calibrate learns about the robot in front of it before the long protocols, from the limits
// protocol's image motion (limits.csv): each servo's measured stops or rim, and its direction as
// the camera sees it. Calibrate applies the learned configuration, in memory, to every protocol
// after the limits protocol (the robot file on disk is never changed), writes it as a corrected
// robot file beside the results and lists every difference from the robot file.
//
// Direction: the limits search measures the signed image shift per +1 us along the servo's image
// axis. With the robot file's stream layout, a pan or the neck with direction +1 (angle to the
// robot's right per +us) moves the scene left in the image (x < 0), a tilt with +1 (up) moves it
// down (y > 0). A servo whose two ends both show the other sign turns the other way from the
// file. When the three x-axis servos (Rx, Lx, Neck) all disagree and the tilts agree, the stream
// is mirrored against the file (robot file image.mirror): that is named, and no direction changed.
//
// Limits: each measured end-stop minus a margin, rounded inward to the 5 us grid, never wider than
// the file's; the socket rim is
// noted but bounds nothing (it is where the image stops being whole, not where the servo must
// stop; the servo sweep's tag sheets carry the fit there). A centre outside the learned range is
// moved inside it.
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "evaluation/limits_eval.h"
#include "fitting/result.h"
#include "models/robot_config.h"
#include "protocols/dataset_tables.h"

namespace owlcal::pipeline {

struct BringUp {
  models::RobotConfig file;     // the robot file's configuration
  models::RobotConfig learned;  // what the rest of the run uses
  // One line per difference the run acted on ("your robot file says -1 for Ly; the robot turns
  // +1; used +1"), and per thing measured but not acted on (a mirrored stream).
  std::vector<std::string> findings;
  std::vector<std::string> notes;  // what could not be measured, and why
  double robot_time_s = 0;         // robot clock of the limits dataset's events [s]
  bool Changed() const;            // learned differs from file
  nlohmann::json ToJson() const;   // results.json diagnostics.bring_up
};

// The measured ends of limits.csv rows; *failed names every probe row that measured nothing
// (status not ok, or no number), *num_rows counts them all.
std::vector<evaluation::LimitMeasurement> LimitMeasurements(const std::vector<protocols::LimitRow>& rows,
                                                            std::vector<std::string>* failed,
                                                            int* num_rows);

// Learns from the limits protocol's rows (any subset of servos and ends).
// margin_us: kept from a measured end-stop beyond the search's stop_error_us
// (protocols/limits_search.h finds stops within 5 us). grid_us: the learned limits are rounded
// inward to multiples of it (5: pigpio's grid; 1: as recorded before the rounding, for refits of
// older datasets).
BringUp LearnFromLimits(const models::RobotConfig& file,
                        const std::vector<protocols::LimitRow>& rows,
                        int margin_us = 10,
                        int stop_error_us = 5,
                        int grid_us = 5);

// The same from a limits dataset folder (limits.csv; robot time from events.log).
BringUp LearnFromLimitsDataset(const models::RobotConfig& file, const std::string& dataset, int grid_us = 5);

// The robot file a calibration run suggests (robot_corrected.yaml beside results.json): the
// configuration the run used (the bring-up's) with each servo's fitted centre (rounded to 1 us,
// kept inside its limits) and scale, and the fitted IPD, wherever the head fit determined them.
// *changes gets one line per field that differs from `file`.
models::RobotConfig CorrectedRobotFile(const models::RobotConfig& file,
                                       const models::RobotConfig& used,
                                       const fitting::CalibrationResult& result,
                                       std::vector<std::string>* changes);

// Robot clock between a dataset's first and last events.log line [s]; 0 without events.
double RobotTimeOfDataset(const std::string& dataset);

}  // namespace owlcal::pipeline
