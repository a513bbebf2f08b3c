#include "protocols/run_plan.h"

#include <string>

#include "protocols/run_context.h"
#include "protocols/runner.h"
#include "protocols/step_plan.h"
#include "robot/limits_guard.h"

namespace owlcal::protocols {

using models::PwmVector;

void CheckProtocolsForRobot(const std::vector<Protocol>& protocols, const models::RobotConfig& robot) {
  for (const Protocol& p : protocols)
    for (const Step& s : p.steps) {
      const std::string why = CheckStepForRobot(s, robot);
      if (!why.empty()) throw ProtocolError(why);
    }
}

std::vector<std::string> PlanRun(const std::vector<Protocol>& protocols,
                                 const models::RobotConfig& robot,
                                 int64_t* num_clamped) {
  CheckProtocolsForRobot(protocols, robot);
  robot::LimitsGuard guard(robot);
  std::vector<std::string> out;
  int64_t clamped = 0;
  int index = 0;
  auto line = [&](const PwmVector& p, const std::string& what) {
    const robot::ClampResult c = guard.Clamp(p);
    std::string l = "    " + PwmText(p) + "  " + what;
    if (c.any_clamped) {
      ++clamped;
      l += "  CLAMPED -> " + PwmText(c.pwm_us) + " (" + c.message + ")";
    }
    out.push_back(l);
  };
  auto poses = [&](const std::vector<PlannedPose>& planned, int frames) {
    for (const PlannedPose& pp : planned)
      line(pp.pwm_us, pp.capture ? "capture " + std::to_string(frames) : "approach");
  };
  auto closed_loop = [&](const ClosedLoopSettings& loop) {
    out.push_back("    closed loop (" + std::string(LocatorName(loop.locator)) +
                  "): commands computed at run time, stopped " + std::to_string(loop.limit_margin_us) +
                  " us inside every limit");
  };
  for (const Protocol& p : protocols) {
    out.push_back("protocol " + p.name + (p.file.empty() ? "" : " (" + p.file + ")") + ", target '" + p.target + "'");
    for (const Step& s : p.steps) {
      out.push_back("  step " + std::to_string(index++) + " " + StepKindName(s.kind()) + " '" + s.name + "'");
      std::visit(
          Overloaded{
              [&](const MoveToStep& m) { line(m.pose.Resolve(robot), "move, capture " + std::to_string(m.frames)); },
              [&](const SweepStep& m) { poses(PlanPoses(m, robot), m.frames); },
              [&](const GridStep& m) { poses(PlanPoses(m, robot), m.frames); },
              [&](const PlaceTargetStep& m) { out.push_back("    place: " + PlacementPrompt(p, m)); },
              [&](const CaptureStep& m) { out.push_back("    capture " + std::to_string(m.frames) + " frames"); },
              [&](const FixateStep& m) { closed_loop(m.loop); },
              [&](const StepResponseStep& m) { closed_loop(m.loop); },
              [&](const LimitsStep& m) {
                for (int servo : m.servos) {
                  PwmVector c = robot.Centre();
                  c[servo] = robot.servos[servo].max_us;
                  line(c, std::string("outermost probe ") + models::kServoNames[servo] + " max");
                  c[servo] = robot.servos[servo].min_us;
                  line(c, std::string("outermost probe ") + models::kServoNames[servo] + " min");
                }
              },
              [&](const AlignmentStep& m) { line(robot.Centre(), "centre, capture " + std::to_string(m.frames)); },
              [&](const LatencyStep& m) {
                PwmVector a = robot.Centre(), b = robot.Centre();
                a[m.servo] -= m.amplitude_us / 2;
                b[m.servo] += m.amplitude_us - m.amplitude_us / 2;
                line(a, "latency step from");
                line(b, "latency step to");
              },
              [&](const WaitStep& m) { out.push_back("    wait " + std::to_string(m.ms) + " ms"); },
              [&](const SaccadeStep& m) {
                out.push_back("    saccades (" + std::string(LocatorName(m.locator)) +
                              "): commands computed at run time from the calibration, stopped " +
                              std::to_string(m.limit_margin_us) + " us inside every limit");
              },
              [&](const VorStep& m) {
                PwmVector a = robot.Centre(), b = robot.Centre();
                double amp = m.sines_hz.empty() ? 0 : m.amplitude_deg;
                for (double s : m.steps_deg) amp = std::max(amp, s);
                const int us = int(std::lround(amp / robot.servos[models::kNeck].nominal_deg_per_us));
                a[models::kNeck] -= us;
                b[models::kNeck] += us;
                line(a, "vor: neck turns to about");
                line(b, "vor: neck turns to about");
                out.push_back("    vor: eye commands computed at run time from the calibration, stopped " +
                              std::to_string(m.limit_margin_us) + " us inside every limit");
              },
              [&](const CatchUpStep& m) {
                out.push_back("    catch-up: " + std::to_string(m.speeds_deg_per_s.size()) +
                              " pursuit trials of a moving target (virtual Owl only), commands computed at run time "
                              "from the calibration, stopped " +
                              std::to_string(m.limit_margin_us) + " us inside every limit");
              },
              [&](const MainSequenceStep& m) {
                const int servo = models::kPanServo[m.eye];
                double amp = 0;
                for (double a : m.amplitudes_deg) amp = std::max(amp, a);
                const int us = int(std::lround(amp / 2 / robot.servos[servo].nominal_deg_per_us));
                PwmVector a = robot.Centre(), b = robot.Centre();
                a[servo] -= us;
                b[servo] += us;
                line(a, "main sequence: the largest saccade from about");
                line(b, "main sequence: the largest saccade to about");
                out.push_back("    main sequence: " + std::to_string(m.amplitudes_deg.size() * m.repeats) +
                              " saccades around the fixation computed at run time from the calibration; a "
                              "saccade within " +
                              std::to_string(m.limit_margin_us) + " us of a limit is skipped, never sent");
              },
              [&](const TrackStep& m) {
                PwmVector a = robot.Centre(), b = robot.Centre();
                for (int e = 0; e < 2; ++e) {
                  const models::ServoConfig& pan = robot.servos[models::kPanServo[e]];
                  const models::ServoConfig& tilt = robot.servos[models::kTiltServo[e]];
                  const double pan_deg = std::max(m.pan_deg, m.leave_deg);
                  a[models::kPanServo[e]] -= int(std::lround(pan_deg / pan.nominal_deg_per_us));
                  b[models::kPanServo[e]] += int(std::lround(pan_deg / pan.nominal_deg_per_us));
                  a[models::kTiltServo[e]] -= int(std::lround(m.tilt_deg / tilt.nominal_deg_per_us));
                  b[models::kTiltServo[e]] += int(std::lround(m.tilt_deg / tilt.nominal_deg_per_us));
                }
                line(a, "track: eyes move about the start pose to about");
                line(b, "track: eyes move about the start pose to about");
                if (m.salience_candidates > 0)
                  out.push_back("    track: " + std::to_string(m.salience_candidates) +
                                " salience fixations computed at run time, stopped " +
                                std::to_string(m.limit_margin_us) + " us inside every limit");
              },
          },
          s.params);
    }
  }
  out.push_back(std::to_string(clamped) + " planned commands would be clamped to the robot's limits");
  if (num_clamped) *num_clamped = clamped;
  return out;
}

}  // namespace owlcal::protocols
