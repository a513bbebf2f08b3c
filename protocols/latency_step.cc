#include "protocols/latency_step.h"

#include <cmath>

#include "protocols/image_motion.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

void RunLatencyStep(RunContext& run, const LatencyStep& s) {
  const models::ServoConfig& sc = run.config().servos[s.servo];
  const int eye = ServoEye(s.servo);
  const int axis = ServoAxis(s.servo);
  const double px_per_us = sc.nominal_deg_per_us * M_PI / 180.0 * NominalFocalPx(run.config());
  const double threshold = std::max(1.0, 0.2 * s.amplitude_us * px_per_us);
  PwmVector base = run.config().Centre();
  for (int trial = 0; trial < s.trials; ++trial) {
    const int sign = trial % 2 == 0 ? 1 : -1;
    PwmVector from = base, to = base;
    from[s.servo] = base[s.servo] - sign * s.amplitude_us / 2;
    to[s.servo] = base[s.servo] + sign * (s.amplitude_us - s.amplitude_us / 2);
    run.Send(from);
    run.Settle(s.settle);
    robot::StereoFrame f0 = run.Grab();
    const cv::Mat ref = MotionThumb(eye == 0 ? f0.left : f0.right, 2);
    const int64_t t_cmd = run.robot().NowNs();
    run.Send(to);
    double latency_ms = NAN, shift = 0;
    int waited = 0;
    for (; waited < s.max_frames; ++waited) {
      robot::StereoFrame f = run.Grab();
      if (s.record_frames) run.Record(f);
      shift = std::abs(ThumbShift(ref, MotionThumb(eye == 0 ? f.left : f.right, 2), 2).px[axis]);
      if (shift > threshold) {
        latency_ms = (f.stamp_ns - t_cmd) * 1e-6;
        break;
      }
    }
    run.writer().AppendRow("latency.csv",
                           "step_index,trial,servo,amplitude_us,latency_ms,frames_waited,shift_px,command_ns,from_us,"
                           "to_us,threshold_px",
                           {std::to_string(run.step_index()),
                            std::to_string(trial),
                            models::kServoNames[s.servo],
                            std::to_string(s.amplitude_us),
                            calib::CsvFixed(latency_ms, 2),
                            std::to_string(waited + 1),
                            calib::CsvFixed(shift, 2),
                            std::to_string(t_cmd),
                            std::to_string(from[s.servo]),
                            std::to_string(to[s.servo]),
                            calib::CsvFixed(threshold, 3)});
    if (run.options().progress)
      *run.options().progress << "  latency trial " << trial << ": " << FixedText(latency_ms, 1) << " ms ("
                              << (waited + 1) << " frames)\n";
  }
}

}  // namespace owlcal::protocols
