#pragma once
// The vor step: the vestibulo-ocular reflex on the calibrated maps (course notes: the eyes
// counter-rotate while the neck turns). Per run of the step:
//   1. Fixation: both eyes centre the protocol's target with the calibration's maps (the target's
//      pixel -> the base-frame point at range_m -> the pulses that centre it, models/saccade.h),
//      up to 8 moves; the fixation pose and each eye's target point X_e are kept.
//   2. Per profile (each sine of sines_hz, then each step of steps_deg) two trials from the
//      fixation pose: "still" (the eyes hold their fixation pulses) and "vor" (the eyes
//      counter-rotate). Every frame (30 fps) the neck is sent to the profile's angle theta(t)
//      through the calibrated neck map (t on the robot's clock from the trial's first frame);
//      in "vor" each eye's pan pulse is the calibrated map's pulse that keeps X_e at its
//      fixation pixel with the neck at its commanded angle (SaccadePulses, pan only).
//      Sine: theta = A sin(2 pi f t) for `cycles` cycles. Step: 0 for 0.5 s, +A for hold_ms, 0 for
//      hold_ms.
//   3. Measured from each frame (calibrated head): the target's pixel; its horizontal angle in
//      the camera (gaze_err_deg, from the calibrated lens); the neck angle that puts X_e on that
//      pixel with the eye at its commanded pulse ("still" trials: the eyes do not move, so the
//      image gives the neck), and in "vor" trials the eye-pan angle that puts X_e on the pixel
//      with the neck the "still" trial measured at the same frame of the profile (the same
//      commands from the same start: on the virtual clock the neck repeats exactly; on a real
//      robot to its repeatability). So gain and phase come from the frames, not from the commands.
//   4. Truth (a robot that has it, robot::SceneControl): the true neck and pan angles at the
//      frame's exposure, the true pixel of the target and its true angle in the camera.
//
// Tables (runner.h):
//   vor.csv         one row per frame and eye (long): step_index,trial,profile,frequency_hz,
//                   amplitude_deg,condition,k,t_s,eye,neck_cmd_us,pan_cmd_us,neck_cmd_deg,pan_cmd_deg,
//                   found,x_px,y_px,gaze_err_deg,neck_deg,pan_deg,true_neck_deg,true_pan_deg,
//                   true_x_px,true_y_px,true_gaze_err_deg (angles: joint angles of the map's
//                   convention, neck + pan = gaze; empty cells = not measured / no truth)
//   vor_trials.csv  one row per trial: step_index,trial,profile,frequency_hz,amplitude_deg,
//                   condition,frames,found_left,found_right,map,message,status,reason
// Trial status: ok when the target was found in at least 90 % of the frames in both eyes; lost
// target below that; not settled when an eye command would come within limit_margin_us of a limit
// (the trial stops before sending it); skipped when the fixation failed.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunVorStep(RunContext& run, const Protocol& p, const VorStep& s);

}  // namespace owlcal::protocols
