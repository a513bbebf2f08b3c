#pragma once
// The catch-up step: smooth pursuit with catch-up saccades of a target moving at constant
// angular speed (course notes: "if objects are moving faster than 30 deg/second a catch-up
// saccade is often required"). Needs a robot that can move the target (robot::SceneControl: the
// virtual Owl); elsewhere every trial is a skipped row saying so.
//
// Per speed (and direction alternating between trials):
//   1. The target (the protocol's, at its placed distance and height from the base origin) is put
//      at azimuth -d v T/2 and one eye fixates it with the calibration's maps.
//   2. For T = duration_ms the target's azimuth moves at v deg/s (then holds): before every frame
//      the step sets the target's pose for the robot clock's time (SetTargetPose; the virtual Owl
//      renders each later frame with the pose in force, so the scene moves in 33 ms steps).
//   3. The controller, per frame: the target's retinal error e (its horizontal angle in the
//      camera, from the calibrated lens). Pursuit: the course's P loop, a pan step of
//      pursuit_gain * e at the servo's nominal scale. Catch-up saccade: when |e| > threshold_deg,
//      one saccade on the calibrated map to where the target will be: its azimuth rate (the
//      target's base-frame azimuth seen in each of the last 6 frames the controller used,
//      through the map at the command in force at that frame's exposure) times the lead (delay
//      + the saccade's move time |e| / slew + 3 lag, the calibration's, else 300 deg/s and 100 ms)
//      ahead of where it is seen; then the frames exposed before the eye can have arrived are ignored (as the saccade
//      step's latency-aware wait: delay = the calibration's exposure delay, else 4 frames).
//   4. Every frame is logged with the action taken and, on the virtual Owl, the true retinal
//      error (the truth head at the frame's exposure angles and the target's pose in force).
// The locator (`locator`, the fixation disc by default) is checked against the target's first
// look (protocols/fixation.h AppearanceCheckedLocator: NCC of the patch inside the disc's card,
// >= 0.85; the disc scores 0.85-0.999, moving or not, wall blobs and the image's darker corners
// less), and a target it loses or mistakes is searched for by that patch near its last position,
// then in the whole image. So a lost target is a lost frame from the image alone: on the default
// robot's nominal maps the whole-image search at every fixation move used to take the darker
// image corner for the disc and the 30 deg/s trial pursued a wall blob, reported ok. The fixation
// before a trial moves at most 8 times and must end within half the saccade threshold of the
// image centre (a servo with a PWM step cannot reach 1 px), else the trial is skipped with why.
// hide_after_ms > 0 turns the target behind the robot that long into each trial (an induced
// loss, for tests); the true error is then not computed.
//
// Tables (runner.h):
//   catch_up.csv         one row per frame: step_index,trial,speed_deg_per_s,direction,k,t_s,
//                        target_az_deg,cmd_us,found,x_px,error_deg,true_error_deg,action
//                        (action: pursuit, saccade, wait, lost, hold; t_s: arrival from the start)
//   catch_up_trials.csv  one row per trial: step_index,trial,speed_deg_per_s,direction,frames,found,
//                        saccades,map,status,reason
// Trial status: ok when the target was found in at least 90 % of the frames; lost target when it
// was missing in 5 consecutive frames (the trial stops; the reason quotes the locator's last
// reason); not settled when a command would come
// within limit_margin_us of a limit (stopped before sending); skipped: no scene control, or the
// fixation failed.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunCatchUpStep(RunContext& run, const Protocol& p, const CatchUpStep& s);

}  // namespace owlcal::protocols
