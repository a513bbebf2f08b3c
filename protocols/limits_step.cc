#include "protocols/limits_step.h"

#include <cmath>

#include "calib/trial_status.h"
#include "models/servo_resolution.h"
#include "protocols/fixation.h"
#include "protocols/limits_search.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

namespace {

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
    const std::optional<Eigen::Vector2d> at = locator->Locate(io.image(), eye);
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
    const int eye = ServoEye(servo);
    const double px_per_us = sc.nominal_deg_per_us * M_PI / 180.0 * focal_px;
    LimitSearchOptions lo;
    lo.coarse_us = s.coarse_us;
    lo.fine_us = s.fine_us;
    lo.moved_fraction = s.moved_fraction;
    lo.rim_fraction = s.rim_fraction;
    lo.check_rim = servo != models::kNeck;  // the neck carries the sockets with the head
    const PwmVector centre = run.config().Centre();
    LimitSearchIo io;
    io.move = [&](int u) {
      PwmVector p = centre;
      p[servo] = u;
      run.Send(p);
      run.Settle(s.settle);
    };
    LimitSearchIo probe_io = io;
    probe_io.move = [&](int u) {
      PwmVector p = centre;
      p[servo] = u;
      run.Send(p);
      SettleRule wait;
      wait.mode = SettleRule::Mode::kTime;
      wait.time_ms = s.resolution_settle_ms;
      run.Settle(wait);
    };
    probe_io.image = [&] {
      robot::StereoFrame f = run.Grab();
      if (s.record_frames) run.Record(f);
      return (eye == models::kLeftEye ? f.left : f.right).clone();
    };
    io.image = [&] {
      robot::StereoFrame f = run.Grab();
      if (s.record_frames) run.Record(f);
      return (eye == models::kLeftEye ? f.left : f.right).clone();
    };
    if (s.resolution_span_us > 0) RunResolutionProbe(run, s, servo, probe_io);
    for (int d : {+1, -1}) {
      if (!s.search_ends) break;
      const int limit = d > 0 ? sc.max_us : sc.min_us;
      const std::string end = d > 0 ? "max" : "min";
      ++ends;
      const int other = d > 0 ? sc.min_us : sc.max_us;
      lo.approach_us = std::min(s.coarse_us, std::abs(centre[servo] - other));
      const LimitSearchResult r = SearchLimit(centre[servo], limit, ServoAxis(servo), px_per_us, lo, io);
      const bool ok = r.status == calib::TrialStatus::kOk;
      // Beyond the rim: the same search from the rim outward with the rim ignored finds an
      // end-stop the rim hides (the phase correlation's window discounts the darkened border), so
      // later protocols are not driven into it.
      std::string beyond_us, beyond_reason;
      if (ok && r.cause == "rim" && r.measured_us != limit) {
        LimitSearchOptions past = lo;
        past.check_rim = false;
        past.approach_us = 0;
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
          "beyond_rim_us,beyond_rim_reason,status,message",
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
