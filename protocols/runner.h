#pragma once
// The protocol runner: executes loaded protocols against a robot (real or virtual, through
// robot::RobotInterface) and records a dataset (protocols/dataset.h).
//
// Safety:
//  - every command passes through robot::LimitsGuard built from the robot's configuration:
//    a value outside the limits is clamped, reported (events.log + progress output, counted
//    in RunSummary::num_clamped) and never sent out of limits;
//  - on an exception or a stop request RunProtocols parks the head at its centre pose (its
//    catch handlers) and closes the dataset as "aborted" or "failed" (Ctrl-C: the caller sets
//    *RunOptions::stop_flag, e.g. from a signal handler; see InstallStopSignals()).
//  - dry-run resolves and prints every planned command and checks it against the limits
//    before anything moves (no robot needed: PlanRun()).
//
// Layout: runner.cc is the step loop; each measurement procedure is a function in its own
// protocols/*_step.h working through protocols/run_context.h (robot I/O, recording, settling);
// run_manifest.h writes the manifest and run_plan.cc the dry-run plan. A new step kind adds a
// *_step.h/.cc pair and one case in Runner::RunStep (and in PlanRun).
//
// Resume: a dataset whose run was interrupted is repaired (CheckDataset/RepairDataset) and
// continued from the first step without a "done" line in steps.csv; the frames of a partly
// run step stay in the dataset (they are valid frames with their commands) and the step is
// run again from its start. The protocols must be the same files (compared by text).
//
// Measurement tables written by the closed-loop steps (columns):
//   fixations.csv      step_index,step_name,placement_index,target,distance_m,eyes,gain,outcome,iterations,
//                      Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,left_found,left_dx_px,left_dy_px,right_found,
//                      right_dx_px,right_dy_px,stamp_ns,approach_Rx,approach_Ry,approach_Lx,approach_Ly,
//                      approach_Neck (sign of the last move of each servo: +1 up, -1 down, 0 unknown),
//                      status,reason (calib/trial_status.h: ok, not settled, lost target, failed; only
//                      ok is ever ranged),left_radius_px,right_radius_px (the target's apparent radius,
//                      empty when the locator does not measure it),target_radius_m (its known radius
//                      from the protocol's `targets`, empty when not given)
//   step_response.csv  step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index
//                      (offset_px along the stepped axis: x for pan, y for tilt; t_s from the step)
//   step_trials.csv    step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,
//                      frames,final_offset_px,message,status,reason (a trial whose fixation failed is a
//                      row with status skipped and the reason)
//   limits.csv         step_index,servo,end,configured_us,measured_us,reason,last_shift_px,rim_darkening,
//                      image_px_per_us,beyond_rim_us,beyond_rim_reason,backlash_us,status,message
//                      (protocols/limits_search.h; image_px_per_us: the signed image shift per +1 us
//                      along the servo's image axis; beyond_rim_*: at a rim end, what the search
//                      found past the rim with the rim ignored: end-stop, configured or unknown;
//                      backlash_us: the width of the backlash band measured at this end, empty when
//                      not measured; measured_us of an end-stop is at approach 0, the middle of that
//                      band; reason: end-stop = the image stopped following the command; rim = the fraction of the 8 px
//                      border band darker than grey 20 grew by more than rim_fraction over the centre pose (protocols/
//                      image_motion.h RimFraction); configured = the robot file's limit reached with neither. status
//                      failed, measured_us empty: a black, constant or motionless image; the step then fails with a
//                      message)
//   resolution.csv     step_index,servo,sample,command_us,position_px,response,status,reason (the limits
//                      step's fine sweep at the centre, resolution_span_us > 0: the fixation target's
//                      position along the servo's axis relative to the first sample [px]; response
//                      unused (empty); fitted by fitting/servo_resolution_fit.h)
//   alignment.csv      step_index,frame_index,method,roll_deg,vertical_offset_px,horizontal_offset_px,corners
//   latency.csv        step_index,trial,servo,amplitude_us,latency_ms,frames_waited,shift_px,command_ns,
//                      from_us,to_us,threshold_px (command_ns: the robot clock when the step was sent;
//                      the step goes from_us -> to_us; motion counts once the shift passes threshold_px;
//                      datasets before 2026-11-26 lack the last four)
//   saccade steps write step_response.csv and step_trials.csv with the columns above (gain 1:
//                      the correction's gain on the map; the message names the map, the saccade
//                      and its corrections)
//   vor.csv            one row per frame and eye of a vor step, vor_trials.csv one row per trial with
//                      status (columns in protocols/vor_step.h)
//   main_sequence.csv  one row per frame of a main-sequence step, main_sequence_trials.csv one row per
//                      saccade with status (columns in protocols/main_sequence_step.h)
//   catch_up.csv       one row per frame of a catch-up step, catch_up_trials.csv one row per trial with
//                      status (columns in protocols/catch_up_step.h)
//   coverage.csv       eye,num_views,x_min,x_max,x_progress,y_min,y_max,y_progress,size_min,size_max,
//                      size_progress,skew_min,skew_max,skew_progress,good (protocols/coverage.h), written
//                      at the end when steps with `detect: true` detected the protocol's target
//                      (observations.csv, calib/observation_io.h, holds the corners).
#include <atomic>
#include <functional>
#include <iosfwd>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "models/head_model.h"

#include "protocols/dataset.h"
#include "protocols/protocol.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols {

struct LiveDetection;  // protocols/live_feedback.h

// What a calibration measured that a controller can use (the saccade step,
// protocols/saccade_step.h): the fitted head (servo maps, eye geometry, intrinsics) and, where
// measured, each servo's slew and lag and the stream's exposure-to-arrival delay. `calibrate`
// fills it from its own fit before it records the saccade protocol.
struct CalibratedMaps {
  models::HeadModel head;
  std::string source;                                      // recorded in events.log and the trial rows
  std::array<double, models::kNumServos> slew_us_per_s{};  // 0: not measured
  std::array<double, models::kNumServos> lag_s{};
  double exposure_delay_s = 0;                             // 0: not measured
  std::array<double, models::kNumServos> resolution_us{};  // PWM step or dead band, whichever is larger; 0 unknown
  // The PWM step the servo rounds pulses to [us] (pigpio: 5); 0 unknown. A saccade seats its
  // commands on that grid, so that the pulse sent is the pulse applied.
  std::array<int, models::kNumServos> pwm_step_us{};
};

struct RunOptions {
  std::string out_dir;  // the dataset folder (required unless dry_run)
  bool dry_run = false;
  bool resume = false;
  bool interactive = false;                // real robot: prompt a person for placements on `input`
  std::istream* input = nullptr;           // answers to prompts (default std::cin)
  std::ostream* progress = nullptr;        // progress lines (nullptr: silent)
  double progress_every_s = 2.0;           // wall-clock seconds between progress lines within a step
  std::atomic<bool>* stop_flag = nullptr;  // set to stop: park, close the dataset as "aborted"
  int64_t frame_timeout_ns = 3'000'000'000;
  // Recorded in the manifest.
  std::string robot_spec;  // "sim" or HOST[:PORT]
  std::string robot_file;  // path of the robot file ("" = built-in default)
  std::string robot_file_text;
  nlohmann::json sim;  // {"seed", "truth_file"} for the virtual Owl, else null
  // Called after each recorded frame (tests, progress).
  std::function<void(int64_t frame_index)> on_frame;
  // Called after the detection of every recorded frame of a `detect: true` step (live capture
  // feedback, protocols/live_feedback.h).
  std::function<void(const LiveDetection&)> on_detection;
  // The calibration closed-loop steps may use (saccade); nullopt: the robot file's nominal head.
  std::optional<CalibratedMaps> calibration;

  bool Check(std::string* why) const;
};

struct RunSummary {
  int num_steps = 0;
  int steps_done = 0;
  int64_t num_frames = 0;   // frames in the dataset at the end
  int64_t num_clamped = 0;  // commands the limits guard changed
  std::vector<std::string> clamp_messages;
  std::string status;  // complete | aborted | failed | dry-run
  std::string message;
  std::vector<std::string> plan;  // dry-run: one line per planned command / step
  double elapsed_s = 0;           // robot clock
};

// Executes the protocols (steps concatenated in order) on `robot`. Throws only for bad
// options; failures during the run are reported in the summary (status failed) after the
// head is parked and the dataset closed.
RunSummary RunProtocols(const std::vector<Protocol>& protocols,
                        robot::RobotInterface& robot,
                        const RunOptions& options);

// The dry-run plan: every command each step would send (closed-loop steps: the range their
// commands are confined to), each line flagged "CLAMPED" when the limits guard would change
// it. *num_clamped counts those lines.
std::vector<std::string> PlanRun(const std::vector<Protocol>& protocols,
                                 const models::RobotConfig& robot,
                                 int64_t* num_clamped);

// Installs a handler for SIGINT, SIGTERM and SIGHUP (Ctrl-C, `timeout`, kill, a closed SSH
// session) that sets the returned flag: the run parks the head and closes the manifest as
// "aborted", naming the signal. A second signal terminates at once (exit 128 + signal).
std::atomic<bool>* InstallStopSignals();

}  // namespace owlcal::protocols
