#pragma once
// The saccade step: a calibrated-map controller. Per amplitude and trial it
//   1. fixates one eye's target with the same controller (both axes, not logged);
//   2. steps the servo away by the amplitude (alternating direction, the robot file's nominal
//      scale: the same step as the step-response step's P loop) and lets it rest 400 ms;
//   3. runs the controller for `frames` frames (longer, up to 3 x frames, until the last move's
//      result has been seen on two frames: a slow stream or servo does not cut a correction off),
//      logging every frame (step_response.csv) and the trial's outcome (step_trials.csv, with
//      status and reason), then goes back.
//
// The controller (one update per frame it is allowed to act on):
//   - saccade: the target's pixel and the head's current joint angles (the calibration's servo
//     maps at the command in force, with the last move's approach for backlash) give the target
//     point at range_m (models/saccade.h PointAtPixel); SaccadePulses finds the pulses that put
//     it on the principal point. With shape: true and a fitted slew and lag for the servo, the
//     first command overshoots by ShapeSaccade's overdrive and the target pulse follows after its
//     switch time (the robot's clock sleeps in between), so the lagging joint arrives sooner; the
//     target pulse is then computed for the approach from beyond (backlash).
//   - latency-aware correction: after every command (its own, and the step's moves away and back)
//     the controller ignores the frames that were exposed before the joint could have arrived:
//     those received before the command's time + move time + delay (the stream's stamps are
//     arrival times), delay = latency_frames / 30 s if set, else the calibration's measured
//     exposure delay, else 4 frames of 30 fps; move time = |step| / slew + 3 lag
//     (ShapeSaccade's settle time when shaped), without a fitted motion 300 deg/s + 100 ms. Then
//     it re-measures and, when the target is more than the dead zone off, steps once more to the
//     map's pulses (a P step of gain 1 on the calibrated map), at most max_corrections times.
//     A frame on which the target moved by more than the dead zone since the frame before is
//     still arriving and is not acted on (nor counted as settled): a motion fit faster than the
//     servo (calibrate's read 489 deg/s for the default robot's 380) ends the wait early, and
//     a correction taken then overshot by 5-8 px.
//   - dead zone: tolerance_px, widened to half the servo's measured resolution (PWM step or dead
//     band) in pixels; a correction that rounds to the command in force is not sent (the servo
//     cannot do better), so the controller never cycles.
//   - safety: a command within limit_margin_us of a limit is never sent (the trial stops, status
//     not settled); the target missing in 5 consecutive usable frames is a lost target.
//
// The calibration is RunOptions::calibration (calibrate fills it from its own fit); without it
// the robot file's nominal head is used and every trial row says so. Trial status: ok when the
// target is found in the last frame within the dead zone; else not settled / lost target /
// skipped (no fixation before the step), with the reason.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunSaccadeStep(RunContext& run, const Protocol& p, const SaccadeStep& s);

}  // namespace owlcal::protocols
