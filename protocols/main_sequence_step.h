#pragma once
// The main-sequence step: saccades of 2-40 deg of one eye's pan, measured from the frames
// (course notes: saccades are ballistic; the Owl's servos reach 300-450 deg/s). Per run:
//   1. Fixation: the eye centres the protocol's target with the calibration's maps (target pixel
//      -> base-frame point X at range_m -> the pulses that centre it, models/saccade.h), up to 8
//      moves; X and the fixation pulses are kept.
//   2. Per amplitude A and repeat r (direction alternating): the pan servo goes to the map's pulse
//      for (fixation angle - d A/2) and rests rest_ms; the step waits for a frame, then a further
//      fraction of a frame period (the golden-ratio sequence over the saccades: the frames sample
//      a different phase of each saccade), notes the robot clock and sends the map's pulse for
//      (fixation angle + d A/2). The target stays within A/2 of the image centre throughout.
//   3. Every one of `frames` frames from the command on is logged: the target's pixel and the
//      eye's pan angle that puts X on that pixel column with the other joints at their commands
//      (from the image through the lens and head geometry, not from the command), and on the
//      virtual Owl (robot::SceneControl) the true pan angle at the frame's exposure.
// A saccade whose pulses would come within limit_margin_us of a limit is a skipped row and is
// never sent. Frame times t_s are arrival times from the command on the robot's clock; the
// exposure delay is fitted downstream (fitting/main_sequence_fit.h).
//
// Tables (runner.h):
//   main_sequence.csv         one row per frame: step_index,saccade,amplitude_deg,repeat,direction,
//                             eye,servo,k,t_s,cmd_us,found,x_px,y_px,angle_deg,true_angle_deg
//                             (angles: the pan joint in the map's convention; empty = not measured)
//   main_sequence_trials.csv  one row per saccade: step_index,saccade,amplitude_deg,repeat,direction,
//                             eye,servo,from_us,to_us,map_amplitude_deg,phase_ms,frames,measured,map,
//                             true_slew_deg_per_s,true_lag_s,status,reason (map_amplitude_deg: the
//                             commanded pulses' angles through the map; true_*: the virtual Owl's
//                             servo truth, empty elsewhere)
// Saccade status: ok when the angle was measured in at least 90 % of its frames; lost target
// below that; skipped (with the reason) when the fixation failed or a pulse would pass the margin.
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunMainSequenceStep(RunContext& run, const Protocol& p, const MainSequenceStep& s);

}  // namespace owlcal::protocols
