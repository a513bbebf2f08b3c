#include "protocols/fixate_step.h"

#include "calib/trial_status.h"

namespace owlcal::protocols {

using models::kNumServos;
using models::PwmVector;

double ExpectedDiscRadiusPx(RunContext& run, const Protocol& p) {
  const auto& placements = run.writer().Placements();
  if (run.placement_index() < 0 || run.placement_index() >= int(placements.size())) return 0;
  const PlacementRecord& pl = placements[run.placement_index()];
  const auto def = p.targets.find(pl.target.empty() ? p.target : pl.target);
  if (def == p.targets.end() || def->second.kind != calib::TargetKind::kFixation) return 0;
  if (!(pl.distance_m > 0) || !(def->second.fixation_radius_m > 0)) return 0;
  return NominalFocalPx(run.config()) * def->second.fixation_radius_m / pl.distance_m;
}

std::unique_ptr<TargetLocator> MakeStepLocator(RunContext& run, const Protocol& p, Locator kind) {
  switch (kind) {
    case Locator::kFixation: {
      calib::FixationDetectorOptions o;
      o.size_hint_px = ExpectedDiscRadiusPx(run, p);
      return MakeFixationLocator(o);
    }
    case Locator::kTemplate:
      return MakeTemplateLocator();
    case Locator::kLk: {
      calib::FixationDetectorOptions o;
      o.size_hint_px = ExpectedDiscRadiusPx(run, p);
      return MakeLkLocator([o] { return MakeFixationLocator(o); });
    }
    case Locator::kAprilTag: {
      // The board centre of the placed target, else of the protocol's target (the geometry from
      // `targets`).
      const auto& placements = run.writer().Placements();
      const int pi = run.placement_index();
      const std::string placed = pi >= 0 && pi < int(placements.size()) ? placements[pi].target : "";
      auto it = p.targets.find(placed);
      if (it == p.targets.end() || it->second.kind == calib::TargetKind::kFixation) it = p.targets.find(p.target);
      if (it == p.targets.end() || it->second.kind == calib::TargetKind::kFixation)
        throw std::runtime_error(p.file + ": locator apriltag needs the placed target" +
                                 (placed.empty() ? std::string() : " '" + placed + "'") +
                                 " or the protocol's target '" + p.target +
                                 "' defined under 'targets' as an aprilgrid or chessboard");
      return MakeBoardLocator(it->second);
    }
  }
  return MakeFixationLocator();
}

FixationOptions FixationFromLoop(const ClosedLoopSettings& loop, const models::RobotConfig& robot) {
  FixationOptions fo;
  fo.max_iterations = loop.max_iterations;
  fo.tolerance_px = loop.tolerance_px;
  fo.still_frames = loop.still_frames;
  fo.latency_frames = loop.latency_frames;
  fo.max_step_us = loop.max_step_us;
  fo.limit_margin_us = loop.limit_margin_us;
  fo.focal_px = NominalFocalPx(robot);
  return fo;
}

void RunFixateStep(RunContext& run, const Protocol& p, const FixateStep& s) {
  if (s.from_centre) {
    run.Send(run.config().Centre());
    run.Settle(SettleRule{});
  }
  auto loc = MakeStepLocator(run, p, s.loop.locator);
  FixationOptions fo = FixationFromLoop(s.loop, run.config());
  fo.gain = s.gain;
  fo.eyes[models::kLeftEye] = Includes(s.eyes, models::kLeftEye);
  fo.eyes[models::kRightEye] = Includes(s.eyes, models::kRightEye);
  const FixationResult r = run.Fixate(fo, *loc, s.loop.record_frames, nullptr);
  // The settled fixation itself is always recorded (one frame).
  const int64_t frame_index = run.Record(run.Grab());
  const PlacementRecord* pl =
      run.placement_index() >= 0 && run.placement_index() < int(run.writer().Placements().size())
          ? &run.writer().Placements()[run.placement_index()]
          : nullptr;
  std::vector<std::string> row = {std::to_string(run.step_index()),
                                  run.step_name(),
                                  std::to_string(run.placement_index()),
                                  pl ? pl->target : "",
                                  pl ? calib::CsvFixed(pl->distance_m, 6) : "",
                                  EyeSetName(s.eyes),
                                  calib::CsvFixed(s.gain, 4),
                                  OutcomeName(r.outcome),
                                  std::to_string(r.iterations)};
  for (int i = 0; i < kNumServos; ++i) row.push_back(std::to_string(r.final_pwm_us[i]));
  for (int e = 0; e < 2; ++e) {
    row.push_back(r.found[e] ? "1" : "0");
    row.push_back(calib::CsvFixed(r.residual_px[e].x(), 3));
    row.push_back(calib::CsvFixed(r.residual_px[e].y(), 3));
  }
  row.push_back(std::to_string(run.robot().NowNs()));
  // The approach of the settled command: backlash shifts the eyes by the hysteresis (~0.25 deg
  // each), which ranging must account for (a vergence run moves both eyes outward in turn).
  for (int i = 0; i < kNumServos; ++i) row.push_back(std::to_string(int(run.approach()[i])));
  // Every fixation is a row with its status (calib/trial_status.h); only "ok" may be ranged.
  std::string reason;
  const calib::TrialStatus status = FixationStatus(r, fo, &reason);
  row.push_back(calib::TrialStatusName(status));
  row.push_back(reason);
  // The target's apparent radius per eye and its known radius: ranging checks that the size and
  // the vergence put it at the same distance (an off-target lock on a background spot does not).
  for (int e = 0; e < 2; ++e) row.push_back(r.radius_px[e] ? calib::CsvFixed(*r.radius_px[e], 3) : "");
  const std::string target_name = pl ? pl->target : p.target;
  const auto def = p.targets.find(target_name);
  row.push_back(def != p.targets.end() && def->second.kind == calib::TargetKind::kFixation
                    ? calib::CsvFixed(def->second.fixation_radius_m, 6)
                    : "");
  run.writer().AppendRow(
      "fixations.csv",
      "step_index,step_name,placement_index,target,distance_m,eyes,gain,outcome,iterations,Rx_us,Ry_us,"
      "Lx_us,Ly_us,Neck_us,left_found,left_dx_px,left_dy_px,right_found,right_dx_px,right_dy_px,stamp_ns,"
      "approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,status,reason,left_radius_px,right_radius_px,"
      "target_radius_m",
      row);
  run.Event("fixate",
            std::string(calib::TrialStatusName(status)) + " (" + OutcomeName(r.outcome) + "): " + r.message +
                " (frame " + std::to_string(frame_index) + ")");
  if (run.options().progress)
    *run.options().progress << "  fixate " << EyeSetName(s.eyes) << " gain " << s.gain << ": "
                            << calib::TrialStatusName(status) << (reason.empty() ? "" : " (" + reason + ")")
                            << " after " << r.iterations << " frames, residual L "
                            << FixedText(r.residual_px[0].norm(), 2) << " px R "
                            << FixedText(r.residual_px[1].norm(), 2) << " px\n";
}

}  // namespace owlcal::protocols
