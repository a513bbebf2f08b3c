#include "protocols/limits_step.h"

#include <cmath>

#include "calib/trial_status.h"
#include "models/servo_resolution.h"
#include "protocols/fixation.h"
#include "protocols/image_motion.h"
#include "protocols/limits_search.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

namespace {

// The eye image of a frame that shows `servo`'s motion.
cv::Mat EyeImage(const robot::StereoFrame& f, int servo) {
  return (ServoEye(servo) == models::kLeftEye ? f.left : f.right).clone();
}

// Sends `servo` to a pulse (the others at their centre) and waits: a settle rule in image mode
// waits its min_ms here and lets WatchUntilStill watch the image after that; in time mode its
// time_ms. Returns the robot clock at the command [ns].
int64_t MoveAndWait(RunContext& run, int servo, int pulse_us, const SettleRule& rule) {
  models::PwmVector p = run.config().Centre();
  p[servo] = pulse_us;
  run.Send(p);
  const int64_t t = run.robot().NowNs();
  run.CheckStop();
  run.robot().SleepNs(int64_t(rule.mode == SettleRule::Mode::kImage ? rule.min_ms : rule.time_ms) * 1'000'000);
  return t;
}

// After MoveAndWait in image mode: later frames until the servo's eye image moved less than
// rule.still_px along the servo's axis between two frames, rule.still_frames times in a row (the
// later ones measured from the run's first frame), or
// rule.max_ms after the command (then not settled, named in events.log). A reference image
// (limits_search.h) is held to half of still_px, so that a first-order lag's remaining travel is
// half as large.
SettledImage WatchUntilStill(RunContext& run,
                             int servo,
                             int64_t command_ns,
                             const SettleRule& rule,
                             bool record,
                             const cv::Mat& image,
                             bool reference) {
  const double still_px = reference ? rule.still_px / 2 : rule.still_px;
  constexpr int kDownsample = 2;
  SettledImage out;
  out.image = image;
  cv::Mat prev = MotionThumb(image, kDownsample);
  cv::Mat run_start;  // the frame a run of still frames started from
  int still = 0;
  // A reference still moving at the first look waits one still frame more, so what is left of
  // the lag shrinks once more.
  auto needed = [&] { return rule.still_frames + (reference && !out.still_at_first_look ? 1 : 0); };
  while (true) {
    const robot::StereoFrame f = run.Grab();
    if (record) run.Record(f);
    ++out.frames;
    out.image = EyeImage(f, servo);
    const cv::Mat cur = MotionThumb(out.image, kDownsample);
    // Along the servo's image axis: across it, phase correlation on a plain wall jitters more.
    auto moved = [&](const cv::Mat& from) { return std::abs(ThumbShift(from, cur, kDownsample).px[ServoAxis(servo)]); };
    const double pair = moved(prev);
    if (out.frames == 1) out.still_at_first_look = pair < rule.still_px;
    // Within a run, the shift is measured from the run's first frame: phase correlation reads a
    // sub-pixel shift between two frames short (it locks to pixels), so a slow creep shows only
    // over several frames.
    if (still > 0 && moved(run_start) < still_px) {
      ++still;
    } else {
      still = pair < still_px ? 1 : 0;
      run_start = prev;
    }
    if (still >= needed()) return out;
    if (f.stamp_ns - command_ns > int64_t(rule.max_ms) * 1'000'000) {
      out.settled = false;
      run.Event("settle",
                std::string(models::kServoNames[servo]) + " at " + std::to_string(run.cmd()[servo]) +
                    " us: the image still moved " + std::to_string(rule.max_ms) + " ms after the command");
      return out;
    }
    prev = cur;
  }
}

// The fine sweep of one servo at its centre (models::ResolutionSweepOffsets), approached from
// below: one resolution.csv row per command with the fixation target's position along the
// servo's image axis relative to the first sample (the disc locator, sub-pixel; image motion on a
// textured wall pixel-locks at this scale). A sweep that would leave the configured range is a
// skipped row, never sent.
void RunResolutionProbe(RunContext& run, const LimitsStep& s, int servo, const LimitSearchIo& io) {
  const models::ServoConfig& sc = run.config().servos[servo];
  const int centre = sc.centre_us, span = s.resolution_span_us;
  const char* header = "step_index,servo,sample,command_us,position_px,response,status,reason";
  const std::string name = models::kServoNames[servo];
  auto row = [&](int sample,
                 int command,
                 const std::string& pos,
                 const std::string& resp,
                 calib::TrialStatus st,
                 const std::string& reason) {
    run.writer().AppendRow("resolution.csv",
                           header,
                           {std::to_string(run.step_index()),
                            name,
                            std::to_string(sample),
                            std::to_string(command),
                            pos,
                            resp,
                            calib::TrialStatusName(st),
                            reason});
  };
  const int below = centre - std::max(2 * span, s.coarse_us);
  if (below < sc.min_us || centre + span > sc.max_us) {
    row(0,
        centre,
        "",
        "",
        calib::TrialStatus::kSkipped,
        "the sweep " + std::to_string(below) + "-" + std::to_string(centre + span) + " us leaves the configured range");
    run.Event("resolution", name + ": skipped, the sweep leaves the configured range");
    return;
  }
  const int axis = ServoAxis(servo);
  const int eye = ServoEye(servo);
  const std::unique_ptr<TargetLocator> locator = MakeFixationLocator();
  io.move(below);  // approach from below: backlash taken up, as the fit assumes
  std::optional<double> first;
  int sample = 0;
  for (const int off : models::ResolutionSweepOffsets(span)) {
    io.move(centre + off);
    cv::Mat img = io.image();
    // The first probe (the move from below) is watched until still; io then waits as long after
    // every later one (RunLimitsStep), so 1 us steps are not judged by a 0.6 px stillness.
    if (sample == 0 && io.settle) img = io.settle(img, true).image;
    const std::optional<Eigen::Vector2d> at = locator->Locate(img, eye);
    if (at && !first) first = (*at)[axis];
    const bool usable = at && first;
    row(sample++,
        centre + off,
        usable ? calib::CsvFixed((*at)[axis] - *first, 4) : "",
        "",
        usable ? calib::TrialStatus::kOk : calib::TrialStatus::kLostTarget,
        usable ? "" : "the fixation target was not found in the image");
  }
  run.Event("resolution", name + ": " + std::to_string(sample) + " probes, span " + std::to_string(span) + " us");
}

}  // namespace

void RunLimitsStep(RunContext& run, const LimitsStep& s) {
  // protocols/limits_search.h: works with any PWM step and dead band; a black, covered or
  // frozen camera fails the step (after its rows are written), never passes as "configured".
  const double focal_px = NominalFocalPx(run.config());
  std::vector<std::string> failed;
  int ends = 0;
  for (int servo : s.servos) {
    const models::ServoConfig& sc = run.config().servos[servo];
    const double px_per_us = sc.nominal_deg_per_us * M_PI / 180.0 * focal_px;
    LimitSearchOptions lo;
    lo.coarse_us = s.coarse_us;
    lo.fine_us = s.fine_us;
    lo.moved_fraction = s.moved_fraction;
    lo.rim_fraction = s.rim_fraction;
    lo.check_rim = servo != models::kNeck;  // the neck carries the sockets with the head
    const PwmVector centre = run.config().Centre();
    // The limits search waits as the step's settle rule says (image mode: its min_ms, then the
    // search watches the image until still where it needs to, limits_search.h).
    const bool image_mode = s.settle.mode == SettleRule::Mode::kImage;
    int64_t command_ns = 0;
    LimitSearchIo io;
    io.move = [&](int u) { command_ns = MoveAndWait(run, servo, u, s.settle); };
    io.image = [&] {
      robot::StereoFrame f = run.Grab();
      if (s.record_frames) run.Record(f);
      return EyeImage(f, servo);
    };
    if (image_mode)
      io.settle = [&](const cv::Mat& img, bool reference) {
        return WatchUntilStill(run, servo, command_ns, s.settle, s.record_frames, img, reference);
      };
    // The resolution probe waits resolution_settle_ms after each command; in image mode its
    // first probe is watched until still and the time that took is added to every later wait.
    SettleRule probe_wait = s.settle;
    if (image_mode)
      probe_wait.min_ms = s.resolution_settle_ms;
    else
      probe_wait.time_ms = s.resolution_settle_ms;
    int64_t probe_extra_ns = 0;
    LimitSearchIo probe_io = io;
    probe_io.move = [&](int u) {
      command_ns = MoveAndWait(run, servo, u, probe_wait);
      run.robot().SleepNs(probe_extra_ns);
    };
    probe_io.image = [&] { return EyeImage(run.Grab(), servo); };
    if (image_mode)
      probe_io.settle = [&](const cv::Mat& img, bool reference) {
        const int64_t t0 = run.robot().NowNs();
        const SettledImage w = WatchUntilStill(run, servo, command_ns, probe_wait, false, img, reference);
        probe_extra_ns = std::max(probe_extra_ns, run.robot().NowNs() - t0);
        return w;
      };
    if (s.resolution_span_us > 0) RunResolutionProbe(run, s, servo, probe_io);
    bool slow = false;  // the first end found the servo slow: the second watches every probe
    for (int d : {+1, -1}) {
      if (!s.search_ends) break;
      const int limit = d > 0 ? sc.max_us : sc.min_us;
      const std::string end = d > 0 ? "max" : "min";
      ++ends;
      const int other = d > 0 ? sc.min_us : sc.max_us;
      lo.approach_us = std::min(s.coarse_us, std::abs(centre[servo] - other));
      lo.watch_every_probe = slow;
      const LimitSearchResult r = SearchLimit(centre[servo], limit, ServoAxis(servo), px_per_us, lo, io);
      slow = slow || r.slow;
      const bool ok = r.status == calib::TrialStatus::kOk;
      // Beyond the rim: the same search from the rim outward with the rim ignored finds an
      // end-stop the rim hides (the phase correlation's window discounts the darkened border), so
      // later protocols are not driven into it.
      std::string beyond_us, beyond_reason;
      if (ok && r.cause == "rim" && r.measured_us != limit) {
        LimitSearchOptions past = lo;
        past.check_rim = false;
        past.approach_us = 0;
        past.measure_backlash = false;
        past.known_backlash_us = r.backlash_us.value_or(0);  // its stop at approach 0 too
        past.watch_every_probe = slow;
        past.judge_speed = false;  // it starts with a long move from the centre
        const LimitSearchResult b = SearchLimit(r.measured_us, limit, ServoAxis(servo), px_per_us, past, io);
        if (b.status == calib::TrialStatus::kOk) {
          beyond_us = std::to_string(b.measured_us);
          beyond_reason = b.cause;
        } else {
          beyond_reason = "unknown";  // no motion measured past the rim: the stop may be anywhere there
        }
      }
      run.writer().AppendRow(
          "limits.csv",
          "step_index,servo,end,configured_us,measured_us,reason,last_shift_px,rim_darkening,image_px_per_us,"
          "beyond_rim_us,beyond_rim_reason,backlash_us,status,message",
          {std::to_string(run.step_index()),
           models::kServoNames[servo],
           end,
           std::to_string(limit),
           ok ? std::to_string(r.measured_us) : "",
           r.cause,
           calib::CsvFixed(r.last_shift_px, 3),
           calib::CsvFixed(r.rim, 4),
           calib::CsvFixed(r.image_px_per_us, 4),
           beyond_us,
           beyond_reason,
           r.backlash_us ? calib::CsvFixed(*r.backlash_us, 2) : "",
           calib::TrialStatusName(r.status),
           r.message});
      const std::string what = std::string(models::kServoNames[servo]) + " " + end;
      if (!ok) failed.push_back(what + ": " + r.message);
      run.Event("limits",
                what + ": configured " + std::to_string(limit) + ", " +
                    (ok ? "measured " + std::to_string(r.measured_us) + " (" + r.cause + "): " : "FAILED: ") +
                    r.message);
      if (run.options().progress)
        *run.options().progress << "  limits " << what << ": configured " << limit << " us, "
                                << (ok ? "measured " + std::to_string(r.measured_us) + " us (" + r.cause + ")"
                                       : "FAILED: " + r.message)
                                << "\n";
    }
  }
  run.Send(run.config().Centre());
  run.Settle(s.settle);
  if (!failed.empty())
    throw std::runtime_error("limits: " + std::to_string(failed.size()) + " of " + std::to_string(ends) +
                             " ends could not be measured (limits.csv names them): " + failed.front() +
                             (failed.size() > 1 ? "; ..." : ""));
}

}  // namespace owlcal::protocols
