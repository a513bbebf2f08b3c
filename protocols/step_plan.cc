#include "protocols/step_plan.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace owlcal::protocols {

std::vector<PlannedPose> PlanPoses(const SweepStep& s, const models::RobotConfig& robot) {
  std::vector<PlannedPose> out;
  const models::PwmVector hold = s.hold.Resolve(robot);
  const int from = s.from.Resolve(robot.servos[s.servo]);
  const int to = s.to.Resolve(robot.servos[s.servo]);
  const int dir = to >= from ? 1 : -1;
  std::vector<int> values;
  for (int v = from; dir > 0 ? v < to : v > to; v += dir * s.step_us) values.push_back(v);
  values.push_back(to);
  auto add = [&](int v, bool capture) {
    PlannedPose p;
    p.pwm_us = hold;
    p.pwm_us[s.servo] = v;
    p.capture = capture;
    out.push_back(p);
  };
  // Pre-approach points are the planner's own: kept inside the limits (dropped when the
  // sweep starts at the limit itself).
  const models::ServoConfig& sc = robot.servos[s.servo];
  auto pre = [&](int end, int v) {
    const int c = sc.Clamp(v);
    if (s.pre_approach && c != end) add(c, false);
  };
  pre(from, from - dir * s.step_us);
  for (int v : values) add(v, true);
  if (s.both_directions) {
    pre(to, to + dir * s.step_us);
    for (auto it = values.rbegin(); it != values.rend(); ++it) add(*it, true);
  }
  return out;
}

std::vector<PlannedPose> PlanPoses(const GridStep& s, const models::RobotConfig& robot) {
  std::vector<PlannedPose> out;
  const models::PwmVector hold = s.hold.Resolve(robot);
  const bool left = Includes(s.eyes, models::kLeftEye), right = Includes(s.eyes, models::kRightEye);
  int row = 0;
  for (int neck : s.neck_us) {
    for (int tilt : s.tilt_us) {
      std::vector<int> pans = s.pan_us;
      if (row++ % 2 == 1) std::reverse(pans.begin(), pans.end());
      for (int pan : pans) {
        PlannedPose p;
        p.pwm_us = hold;
        auto add = [&](int servo, int offset) { p.pwm_us[servo] += robot.servos[servo].direction * offset; };
        if (left) {
          add(models::kLx, pan);
          add(models::kLy, tilt);
        }
        if (right) {
          add(models::kRx, pan);
          add(models::kRy, tilt);
        }
        add(models::kNeck, neck);
        out.push_back(p);
      }
    }
  }
  return out;
}

Eigen::Isometry3d PlacementPose(const PlaceTargetStep& s, const calib::TargetDefinition* target) {
  const double d2r = M_PI / 180.0;
  const Eigen::Matrix3d r = (Eigen::AngleAxisd(s.rpy_deg.z() * d2r, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(s.rpy_deg.y() * d2r, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(s.rpy_deg.x() * d2r, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  const Eigen::Vector3d centre(s.offset_m.x(), s.offset_m.y(), s.distance_m);
  Eigen::Vector3d centre_in_target = Eigen::Vector3d::Zero();
  if (target && target->kind != calib::TargetKind::kFixation) {
    const Eigen::Vector4d e = target->Extent();
    centre_in_target = Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0);
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = r;
  pose.translation() = centre - r * centre_in_target;
  return pose;
}

Eigen::Isometry3d HiddenPose() {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(50.0, 0.0, 1.0);
  return pose;
}

std::string PlacementPrompt(const Protocol& p, const PlaceTargetStep& s) {
  if (!s.prompt.empty()) return s.prompt;
  std::ostringstream o;
  std::string what = p.target_description.empty() ? s.target : p.target_description;
  o << "Place the " << what << " target " << std::lround(s.distance_m * 1000) << " mm in front of the neck axis";
  if (s.offset_m.norm() > 0)
    o << ", centre offset " << std::lround(s.offset_m.x() * 1000) << " mm right and "
      << std::lround(s.offset_m.y() * 1000) << " mm down";
  if (s.rpy_deg.norm() > 0)
    o << ", turned roll " << s.rpy_deg.x() << " deg, pitch " << s.rpy_deg.y() << " deg, yaw " << s.rpy_deg.z()
      << " deg";
  o << ", then press Enter (or type the measured distance in mm)";
  return o.str();
}

double StepWork(const Step& step) {
  switch (step.kind()) {
    case StepKind::kSweep: {
      const int n = 2 * 13;  // typical; refined below when resolvable without a robot
      return n * (4 + step.As<SweepStep>().frames);
    }
    case StepKind::kGrid: {
      const GridStep& s = step.As<GridStep>();
      return double(s.pan_us.size() * s.tilt_us.size() * s.neck_us.size()) * (4 + s.frames);
    }
    case StepKind::kMoveTo:
      return 4 + step.As<MoveToStep>().frames;
    case StepKind::kCapture:
      return 2 + step.As<CaptureStep>().frames;
    case StepKind::kFixate:
      return step.As<FixateStep>().loop.max_iterations / 2.0;
    case StepKind::kStepResponse: {
      const StepResponseStep& s = step.As<StepResponseStep>();
      return double(s.gains.size() * s.amplitudes_deg.size() * s.trials) * (s.frames + 40);
    }
    case StepKind::kLimits:
      return step.As<LimitsStep>().servos.size() * 2 * 40.0;
    case StepKind::kAlignment:
      return 4 + step.As<AlignmentStep>().frames;
    case StepKind::kLatency:
      return step.As<LatencyStep>().trials * 15.0;
    case StepKind::kSaccade: {
      const SaccadeStep& s = step.As<SaccadeStep>();
      return double(s.amplitudes_deg.size() * s.trials) * (s.frames + 20);
    }
    case StepKind::kVor: {
      // Frames at 30 fps, both conditions, plus the fixation.
      const VorStep& s = step.As<VorStep>();
      double seconds = 0;
      for (double hz : s.sines_hz) seconds += s.cycles / hz + 1;
      seconds += s.steps_deg.size() * (0.5 + 2 * s.hold_ms / 1000.0 + 1);
      return 2 * 30 * seconds + 30;
    }
    case StepKind::kMainSequence: {
      const MainSequenceStep& s = step.As<MainSequenceStep>();
      return double(s.amplitudes_deg.size() * s.repeats) * (s.frames + 1) + 30;
    }
    case StepKind::kCatchUp: {
      const CatchUpStep& s = step.As<CatchUpStep>();
      return double(s.speeds_deg_per_s.size()) * ((s.duration_ms + s.hold_ms) / 1000.0 * 30 + 20);
    }
    case StepKind::kTrack: {
      const TrackStep& s = step.As<TrackStep>();
      double seconds = s.cycles / s.frequency_hz + 1;
      if (s.leave_deg > 0) seconds += (s.leave_ms + s.return_ms) / 1000.0;
      return 30 * seconds + s.salience_candidates * 60.0;
    }
    case StepKind::kPlaceTarget:
    case StepKind::kWait:
      return 1;
  }
  return 1;
}

}  // namespace owlcal::protocols
