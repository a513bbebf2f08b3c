#include "protocols/limits_step.h"

#include <cmath>

#include "calib/trial_status.h"
#include "protocols/limits_search.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

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
    io.image = [&] {
      robot::StereoFrame f = run.Grab();
      if (s.record_frames) run.Record(f);
      return (eye == models::kLeftEye ? f.left : f.right).clone();
    };
    for (int d : {+1, -1}) {
      const int limit = d > 0 ? sc.max_us : sc.min_us;
      const std::string end = d > 0 ? "max" : "min";
      ++ends;
      const LimitSearchResult r = SearchLimit(centre[servo], limit, ServoAxis(servo), px_per_us, lo, io);
      const bool ok = r.status == calib::TrialStatus::kOk;
      run.writer().AppendRow(
          "limits.csv",
          "step_index,servo,end,configured_us,measured_us,reason,last_shift_px,rim_darkening,status,message",
          {std::to_string(run.step_index()),
           models::kServoNames[servo],
           end,
           std::to_string(limit),
           ok ? std::to_string(r.measured_us) : "",
           r.cause,
           calib::CsvFixed(r.last_shift_px, 3),
           calib::CsvFixed(r.rim, 4),
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
