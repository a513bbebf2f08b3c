#pragma once
// The search for one end of one servo's usable range (the limits protocol, protocols/runner.h
// limits.csv): the servo is stepped outward from its centre, every other servo at its centre,
// until the image stops following the command (a physical end-stop), the eye-socket rim
// darkens the image border, or the configured limit is reached.
//
// It works with any PWM step and dead band (models/servo_resolution.h), with slow, laggy servos
// and backlash, and finds a stop anywhere inside the configured range, including inside the last
// coarse step:
//   0. Waiting: after each move the caller waits its minimum time (LimitSearchIo::move); with
//      LimitSearchIo::settle the search then watches the centre's image until it stops moving.
//      A servo still moving at that first look after the wait (LimitSearchResult::slow) has
//      every later probe watched too, the anchor and the backlash probe (references, like the
//      centre) more strictly; for one that was still (a fast servo), only a coarse step that
//      moved less than expected is watched before it is acted on, so a fast servo costs about
//      one frame per probe.
//   1. Image check: the eye image at the centre must show texture (grey standard deviation of
//      the motion thumbnail >= min_contrast_grey). A black, covered (lens cap) or constant
//      image fails the search: it shows no motion, so it can neither find nor rule out a stop.
//   2. Coarse: the centre is approached from the other end's side (approach_us: the backlash
//      taken up towards this end), then steps of coarse_us outward. A step whose image shift is below
//      moved_fraction of the nominal shift ends the coarse walk. When that is the FIRST step
//      from the centre, it is retried as one longer step (up to first_step_tries coarse steps
//      from the centre: a dead band, backlash or a slow servo can swallow one coarse step); if
//      none moved, the search fails (the camera shows no motion: frozen or covered, or the servo
//      does not move): a stop at the centre is never reported. The image scale (px per us) is
//      the median over the coarse steps that moved.
//   3. Fine, always (also when the coarse walk reached the configured limit): from an anchor
//      one coarse step inside the last good coarse pulse, approached from the inside (backlash
//      taken up), steps of fine_us outward. The image position is measured against the anchor
//      image (cumulative shift / measured scale = travel the servo applied), so a fine step
//      that produces no motion because of the PWM step or dead band is not a stop. A stop is
//      when the commanded travel exceeds the measured travel by more than max(8 us, 2 fine_us)
//      beyond the bias (the median disagreement of the probes that moved: the anchor's own
//      rounding), and the next fine step shows it too (the retry: a dead band that swallowed
//      the probe accepts the next one; a stop stays a stop). The stop the probes met is the
//      anchor plus the largest measured travel plus the bias, rounded inward.
//   4. At the configured limit with the image following: "configured", unless the servo
//      applied more than 4 us less than the limit (a stop just inside it: "end-stop" there).
//      The limit's probe jumps there from one coarse step inside, so that a dead band larger
//      than the fine step cannot leave the servo short of the limit.
//   5. Backlash (measure_backlash): the centre is approached again from outside (from one coarse
//      step beyond it, so dead bands up to coarse_us / 2 are passed); the image's outward travel
//      against the centre's image from inside is the width of the backlash band (2 hysteresis_us
//      of models/servo_map.h; at the centre, so that no stop cuts it short). The probes approach a
//      stop from inside, where a servo meets it half a band later than at approach 0, so an
//      end-stop is reported at approach 0 (the stop the probes met minus half the band, rounded
//      inward), as sim/robot_truth.h defines stops. Without the measurement, known_backlash_us
//      (the band found before, e.g. by the search up to the rim) serves the same way.
// The rim (eyes only): RimFraction of the eye image grew by more than rim_fraction over the
// centre pose; the end is then the last fine pulse without it (a command from inside).
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "calib/trial_status.h"

namespace owlcal::protocols {

// Step 3's stop test, shared with the interactive jog (protocols/jog.h): fed, probe after probe
// outward from an anchor, the commanded travel and the travel the image shows (both in us), it
// tells when the image stopped following. Only probes that clearly moved (travel grew by at least
// moved_us) enter the bias, so a stop creeping in, where the travel no longer grows, does not drag
// it along; the bias is bounded by the rounding of PWM steps up to 10 us.
class StopDetector {
 public:
  StopDetector(double tolerance_us, double moved_us) : tolerance_us_(tolerance_us), moved_us_(moved_us) {}
  // True when commanded - travel exceeds the bias by more than the tolerance: a stop.
  bool Stopped(double commanded_us, double travel_us);
  // Outward from the anchor, where the servo stopped: the largest travel seen plus the bias.
  double StopTravel() const { return travel_max_ + bias_; }
  double bias() const { return bias_; }

 private:
  double tolerance_us_, moved_us_;
  double bias_ = 0, travel_max_ = 0, prev_travel_ = 0;
  std::vector<double> moved_deficits_;
};

struct LimitSearchOptions {
  int coarse_us = 20;
  int fine_us = 4;
  double moved_fraction = 0.3;
  double rim_fraction = 0.02;
  bool check_rim = true;         // false for the neck (it carries the sockets with the head)
  double min_contrast_grey = 4;  // thumbnail grey std below this: black or constant image
  int first_step_tries = 3;      // coarse steps from the centre tried before "no image motion"
  // The centre is first approached from this far on the other end's side [us] (the caller keeps
  // it inside the configured range); 0: not.
  int approach_us = 0;
  bool measure_backlash = true;    // step 5; false: not measured (known_backlash_us, if > 0, is used)
  double known_backlash_us = 0;    // the band measured before (the same servo's search up to the rim) [us]
  bool watch_every_probe = false;  // watch every probe until still (a servo known to be slow)
  // Judge the servo fast or slow from the centre's first look (step 0); false: as
  // watch_every_probe says (a search that starts after a long move, e.g. past the rim).
  bool judge_speed = true;
  bool Check(std::string* why) const;
};

// The image the search watched until it stopped moving (LimitSearchIo::settle).
struct SettledImage {
  cv::Mat image;        // the last frame looked at
  int frames = 0;       // frames grabbed after the given one
  bool settled = true;  // false: still moving when the caller's time ran out
  // The first later frame moved less than a probe may (for a reference too): the wait was long
  // enough for this servo.
  bool still_at_first_look = true;
};

// What the search needs: move this servo to a pulse (others at their centre) and wait (the
// caller's minimum time, or a fixed time); the eye image after that (8-bit BGR or grey); and,
// optionally, from the image just taken, later frames until the image stops moving (empty: the
// wait of move is trusted); `reference`: an image others are measured against (the centre, the
// anchor, the backlash probe), to be watched until it moves less than a probe must.
struct LimitSearchIo {
  std::function<void(int pulse_us)> move;
  std::function<cv::Mat()> image;
  std::function<SettledImage(const cv::Mat& image, bool reference)> settle;
};

struct LimitSearchResult {
  calib::TrialStatus status = calib::TrialStatus::kOk;  // ok, or failed (no usable image/motion)
  std::string cause;                                    // ok: "end-stop", "rim" or "configured"; failed: ""
  std::string message;                                  // failed: why; ok: how it was found
  int measured_us = 0;                                  // the usable end (failed: the centre, never to be used)
  double last_shift_px = 0;                             // image shift of the last probe
  double rim = 0;                                       // rim darkening of the last probe over the centre pose
  double px_per_us = 0;                                 // measured image scale
  // The image's shift along the axis per +1 us of command [px/us], signed (x right, y down): its
  // sign is the servo's direction as the camera sees it; 0 when no coarse step moved.
  double image_px_per_us = 0;
  int probes = 0;
  // Step 5: the width of the backlash band [us] (2 hysteresis_us); nullopt when not measured.
  std::optional<double> backlash_us;
  // An end-stop: the pulse at which the probes (from inside) met it; measured_us is that minus
  // half the backlash band (approach 0). Otherwise measured_us.
  int met_us = 0;
  bool slow = false;  // the image still moved at the centre's first look after the wait
  int watched = 0;    // probes watched until still
  int unsettled = 0;  // watched probes still moving when the caller's time ran out
  int retries = 0;    // stops not confirmed by the next fine step (a dead band)
};

// centre_us, limit_us: the configured centre and the configured limit of this end (either
// side of the centre); axis 0 = the image moves in x (pan, neck), 1 = y (tilt);
// nominal_px_per_us > 0: the expected image shift per us. Throws std::invalid_argument on bad
// options.
LimitSearchResult SearchLimit(int centre_us,
                              int limit_us,
                              int axis,
                              double nominal_px_per_us,
                              const LimitSearchOptions& options,
                              const LimitSearchIo& io);

}  // namespace owlcal::protocols
