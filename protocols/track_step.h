#pragma once
// The track step (issue 16 item 3, course notes: salience and Lucas-Kanade tracking, Annex 7):
//   1. Salience (salience_candidates > 0): at the start pose one frame is recorded; the right eye's
//      salience map (calib/salience.h: Itti-Koch-style intensity, colour and orientation DoG
//      channels) ranks candidate targets. For each candidate the right eye fixates it from the start
//      pose with the fixation loop (protocols/fixation.h, the step's gain) on a Lucas-Kanade
//      tracker seeded at the candidate's pixel (MakeLkLocator + MakePixelLocator, no reacquisition:
//      a lost candidate is lost). On a robot with truth (robot::SceneControl) each candidate is
//      compared with the scene: the object whose true outline contains its pixel (the projected
//      quad of its extent: a board with its margin, a fixation disc with its white card of twice
//      the disc's diameter) and the pixel distance to that object's projected centre (to the
//      nearest object's when none contains it);
//      after the fixation, the object at the right eye's image centre.
//   2. Tracking: from the start pose both eyes move through a figure of eight on the robot file's
//      nominal scales (pan offset pan_deg sin(2 pi f t), tilt offset tilt_deg sin(4 pi f t), t on the
//      robot's clock from the first frame), then, with leave_deg > 0, pan leave_deg to the robot's
//      right (the target leaves the view) for leave_ms and come back for return_ms. Every frame the
//      protocol's target is located in both eyes by two trackers started on the first frame: the
//      fixation locator (the disc detector near its last position, checked against the disc's first
//      look, protocols/fixation.h AppearanceCheckedLocator; a miss or a blob that does not look
//      like the disc is searched for by that look near the last position, then in the whole image:
//      "reacquired" when that finds it, else "lost" with why; it used to take wall blobs and the
//      image's darker corners for the disc while the disc was out of view) and LK (MakeLkLocator
//      seeded and reacquired by the fixation locator). Truth: the target's true pixel at the
//      frame's exposure.
// A command that would come within limit_margin_us of a limit is not sent: the trial stops and its
// row says so (status not_settled).
//
// Tables (runner.h):
//   track.csv          one row per frame, eye and tracker: step_index,phase,k,t_s,eye,tracker,
//                      pan_cmd_us,tilt_cmd_us,status,found,x_px,y_px,reason,true_x_px,true_y_px,
//                      true_in_view (status: ok | reacquired | lost; empty cells: no position / no truth)
//   track_trials.csv   one row per tracking run: step_index,frames,phases,status,reason
//   salience.csv       one row per candidate: step_index,frame_index,rank,x_px,y_px,score,intensity,
//                      colour,orientation,object,object_distance_px,object_radius_px,fix_status,
//                      fix_reason,fix_iterations,fix_dx_px,fix_dy_px,fixated_object,fixated_distance_px
//   salience_map.csv   the right eye's map every 4 px: step_index,x_px,y_px,salience
#include "protocols/protocol.h"
#include "protocols/run_context.h"

namespace owlcal::protocols {

void RunTrackStep(RunContext& run, const Protocol& p, const TrackStep& s);

}  // namespace owlcal::protocols
