#pragma once
// A servo's slew rate and lag (and the stream's exposure delay, within the window the latency
// protocol allows) from recorded step responses: the frames of a step trial (each with the time
// it arrived, the target's image offset along the axis and the command in force when it arrived).
//
// Model (fitting/loop_model.h, the same in reverse): the commands, replayed through the servo's
// resolution (models/servo_resolution.h) from the segment's initial applied pulse and approach,
// give the joint's target position applied - hysteresis_us * approach [us]; a command that
// changed between frames k-1 and k was sent command_delay_s after frame k-1 arrived; the joint
// follows models::SlewLagTrajectory (slew_us_per_s, lag_s) from rest; frame k shows the joint at
// t_k - exposure_delay_s, and its offset is
//   offset_k = a_segment - px_per_us * joint(t_k - exposure_delay_s)    [px]
// with one a per segment (where the target is) and one px_per_us for all. a and px_per_us are
// solved in closed form for every (slew, lag, delay); those three are found by a grid search
// refined coordinate by coordinate, and their sigmas come from the Jacobian of the residuals
// (with a, px_per_us re-solved) scaled by the residual RMS. A parameter whose relative sigma is
// above 30 % is reported as not determined by the data (e.g. the slew of small steps or a slow
// servo's steps, where the lag and the latency explain the frames as well); with a prior for it
// (prior_slew_us_per_s, prior_lag_s) it is then held at the prior and the others fitted again,
// and the result says so (slew_from_prior, lag_from_prior): an undetermined number is never
// reported as if measured (the unconstrained search runs the slew out to 1e9 us/s).
#include <string>
#include <vector>

#include "models/servo_resolution.h"

namespace owlcal::fitting {

struct MotionFrame {
  double t_s = 0;        // arrival time (any origin, increasing within a segment)
  double offset_px = 0;  // target offset along the servo's image axis
  bool found = true;     // false: the frame only carries the command
  int command_us = 0;    // command in force when the frame arrived
};

struct MotionSegment {
  std::string name;                 // "gain 0.1, 10 deg, trial 0"
  std::vector<MotionFrame> frames;  // the joint is at rest at frames[0]
  int initial_approach = 0;         // approach of the pulse in force at frames[0]
};

struct ServoMotionFitOptions {
  double fps = 30;
  double exposure_delay_min_s = 0.02, exposure_delay_max_s = 0.25;  // from the latency protocol
  double command_delay_s = 0.001;
  double hysteresis_us = 0;
  models::ServoResolution resolution;
  double prior_slew_us_per_s = 0;  // > 0: an undetermined slew is held here [us/s]; 0: none
  double prior_lag_s = -1;         // >= 0: an undetermined lag is held here [s]; < 0: none
  bool Check(std::string* why) const;
};

struct ServoMotionFit {
  bool ok = false;
  std::string message;
  double slew_us_per_s = 0, slew_sigma_us_per_s = 0;
  double lag_s = 0, lag_sigma_s = 0;
  double exposure_delay_s = 0, exposure_delay_sigma_s = 0;
  bool slew_determined = false, lag_determined = false;
  // Not determined, so held at the options' prior (then its sigma is 0 and determined false).
  bool slew_from_prior = false, lag_from_prior = false;
  double px_per_us = 0;  // signed
  double rms_px = 0;
  int num_frames = 0, num_segments = 0;
};

ServoMotionFit FitServoMotion(const std::vector<MotionSegment>& segments, const ServoMotionFitOptions& options);

}  // namespace owlcal::fitting
