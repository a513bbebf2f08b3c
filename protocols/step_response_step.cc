#include "protocols/step_response_step.h"

#include <cmath>

#include "calib/trial_status.h"
#include "protocols/fixate_step.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

void RunStepResponseStep(RunContext& run, const Protocol& p, const StepResponseStep& s) {
  const int eye = s.eye;
  const bool pan = s.axis == Axis::kPan;
  const int servo = pan ? models::kPanServo[eye] : models::kTiltServo[eye];
  const models::ServoConfig& sc = run.config().servos[servo];
  auto loc = MakeStepLocator(run, p, s.loop.locator);
  int trial_counter = 0;
  for (double gain : s.gains) {
    for (double amp : s.amplitudes_deg) {
      for (int trial = 0; trial < s.trials; ++trial, ++trial_counter) {
        // 1) Fixate with a safe, latency-aware loop.
        FixationOptions acquire = FixationFromLoop(s.loop, run.config());
        acquire.eyes[0] = eye == models::kLeftEye;
        acquire.eyes[1] = eye == models::kRightEye;
        acquire.gain = 0.3;
        acquire.latency_frames = 4;
        acquire.max_iterations = 150;
        acquire.tolerance_px = std::max(1.0, s.loop.tolerance_px);
        const FixationResult a = run.Fixate(acquire, *loc, false, nullptr);
        const PwmVector fix = run.cmd();
        std::vector<std::string> trial_row = {std::to_string(run.step_index()),
                                              calib::CsvFixed(gain, 4),
                                              calib::CsvFixed(amp, 3),
                                              std::to_string(trial),
                                              models::kEyeNames[eye],
                                              AxisName(s.axis),
                                              models::kServoNames[servo]};
        std::string acquire_reason;
        const calib::TrialStatus acquired = FixationStatus(a, acquire, &acquire_reason);
        if (acquired != calib::TrialStatus::kOk) {
          // The trial is a row too: skipped, saying why.
          const std::string why =
              std::string("no fixation before the step: ") + calib::TrialStatusName(acquired) + ": " + acquire_reason;
          trial_row.insert(trial_row.end(),
                           {"",
                            PwmText(fix),
                            "no-fixation",
                            "0",
                            "",
                            a.message,
                            calib::TrialStatusName(calib::TrialStatus::kSkipped),
                            why});
          run.writer().AppendRow(
              "step_trials.csv",
              "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,"
              "final_offset_px,message,status,reason",
              trial_row);
          run.Event("step-response", "trial skipped: " + why);
          if (run.options().progress)
            *run.options().progress << "  step " << FixedText(amp, 0) << " deg gain " << FixedText(gain, 3)
                                    << ": skipped (" << why << ")\n";
          continue;
        }
        // 2) Step away by the amplitude (alternating direction), settle.
        const int sign = (trial_counter % 2 == 0) ? 1 : -1;
        const int delta = static_cast<int>(std::lround(sign * amp / sc.nominal_deg_per_us));
        PwmVector away = fix;
        away[servo] += delta;
        run.Send(away);
        SettleRule rest;
        rest.mode = SettleRule::Mode::kTime;
        rest.time_ms = 400;
        run.Settle(rest);
        const PwmVector start = run.cmd();
        // 3) Closed loop for a fixed number of frames, logging every frame.
        FixationOptions fo = FixationFromLoop(s.loop, run.config());
        fo.eyes[0] = eye == models::kLeftEye;
        fo.eyes[1] = eye == models::kRightEye;
        fo.pan = pan;
        fo.tilt = !pan;
        fo.gain = gain;
        fo.max_iterations = s.frames;
        fo.stop_when_converged = false;
        std::vector<int64_t> frames;
        const FixationResult r = run.Fixate(fo, *loc, s.loop.record_frames, &frames);
        const int64_t t0 = r.trace.empty() ? 0 : r.trace.front().stamp_ns;
        for (size_t k = 0; k < r.trace.size(); ++k) {
          const FixationSample& fs = r.trace[k];
          const Eigen::Vector2d off = fs.offset_px[eye];
          run.writer().AppendRow(
              "step_response.csv",
              "step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index",
              {std::to_string(run.step_index()),
               calib::CsvFixed(gain, 4),
               calib::CsvFixed(amp, 3),
               std::to_string(trial),
               std::to_string(k),
               calib::CsvFixed((fs.stamp_ns - t0) * 1e-9, 6),
               calib::CsvFixed(pan ? off.x() : off.y(), 3),
               calib::CsvFixed(pan ? off.y() : off.x(), 3),
               std::to_string(fs.pwm_us[servo]),
               fs.found[eye] ? "1" : "0",
               std::to_string(k < frames.size() ? frames[k] : -1)});
        }
        const double final_off = r.found[eye] ? (pan ? r.residual_px[eye].x() : r.residual_px[eye].y()) : NAN;
        std::string reason;
        const calib::TrialStatus status = FixationStatus(r, fo, &reason);
        trial_row.insert(trial_row.end(),
                         {std::to_string(start[servo]),
                          std::to_string(fix[servo]),
                          OutcomeName(r.outcome),
                          std::to_string(r.iterations),
                          calib::CsvFixed(final_off, 3),
                          r.message,
                          calib::TrialStatusName(status),
                          reason});
        run.writer().AppendRow(
            "step_trials.csv",
            "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,"
            "final_offset_px,message,status,reason",
            trial_row);
        run.Event("step-response",
                  "gain " + FixedText(gain, 3) + " amplitude " + FixedText(amp, 1) +
                      " deg: " + calib::TrialStatusName(status) + " (" + OutcomeName(r.outcome) + ") " + r.message);
        if (run.options().progress)
          *run.options().progress << "  step " << FixedText(amp, 0) << " deg gain " << FixedText(gain, 3) << ": "
                                  << calib::TrialStatusName(status) << ", final offset " << FixedText(final_off, 2)
                                  << " px\n";
        // 4) Back to the fixation pose.
        run.Send(fix);
        run.Settle(rest);
      }
    }
  }
}

}  // namespace owlcal::protocols
