// Regression: fixation and vergence ranging on robots whose servos do not apply the pulse they are
// commanded: 5 us PWM steps and dead bands of 2-5 us (tests/data/robots/owl_step5_truth.yaml,
// owl_deadband_truth.yaml, data/sim/owl_variant_a_truth.yaml with 4-8 us backlash). The fixation
// seats its settled command (protocols/fixation.h), so the command is the pulse the servo
// applies and ranging at it is as good as the maps: with the TRUE head, every range within 1 %.
#include <cmath>
#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>

#include "evaluation/ranging_eval.h"
#include "models/head_kinematics.h"
#include "owlcal_version.h"
#include "protocols/dataset_tables.h"
#include "protocols/fixation.h"
#include "protocols/step_plan.h"
#include "robot/limits_guard.h"
#include "sim/robot_truth.h"
#include "tests/protocols/suite_helpers.h"

namespace owlcal::protocols {
namespace {

sim::VirtualOwlOptions RobotOptions(const std::string& truth_file) {
  sim::VirtualOwlOptions vo;
  vo.truth = sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/" + truth_file);
  vo.seed = 3;
  return vo;
}

const char* const kStep5 = "tests/data/robots/owl_step5_truth.yaml";
const char* const kDeadBand = "tests/data/robots/owl_deadband_truth.yaml";
const char* const kVariantA = "data/sim/owl_variant_a_truth.yaml";

// One fixation loop on each robot: ok, seated on the 5 us grid, and every servo applies exactly
// the command (the truth's joint angles are the truth maps at the command with its approach).
void ExpectFixationOnAppliedPulses(const char* file) {
  {
    for (double distance : {0.3, 1.2}) {
      sim::VirtualOwl owl(RobotOptions(file));
      robot::LimitsGuard guard(owl.Config());
      models::PwmVector cmd = owl.Config().Centre();
      std::vector<models::PwmVector> sent;
      int64_t last = -1;
      FixationIo io;
      io.command = [&] { return cmd; };
      io.send = [&](const models::PwmVector& p) {
        cmd = guard.Clamp(p).pwm_us;
        sent.push_back(cmd);
        owl.SendServos(cmd);
      };
      io.grab = [&] {
        auto f = owl.GrabFrame(last, 1'000'000'000);
        last = f->stamp_ns;
        return *f;
      };
      PlaceTargetStep s;
      s.target = "fixation";
      s.distance_m = distance;
      s.offset_m = Eigen::Vector2d(0.03, 0.01);
      owl.SetTargetPose("fixation", PlacementPose(s, nullptr));
      for (const std::string& n : owl.TargetNames())
        if (n != "fixation") owl.SetTargetPose(n, HiddenPose());
      owl.SendServos(cmd);
      owl.SleepNs(300'000'000);
      FixationOptions o;
      o.gain = 0.1;
      o.tolerance_px = 1.5;
      o.max_iterations = 200;
      auto loc = MakeFixationLocator();
      const FixationResult r = RunFixation(o, owl.Config(), *loc, io);
      const std::string at = std::string(file) + " at " + std::to_string(distance) + " m";
      std::string reason;
      EXPECT_EQ(FixationStatus(r, o, &reason), calib::TrialStatus::kOk) << at << ": " << reason << " " << r.message;
      ASSERT_TRUE(r.seated) << at;
      const models::HeadModel truth = owl.TruthHeadModel();
      auto f = owl.GrabFrame(last, 1'000'000'000);
      const sim::FrameTruth ft = owl.TruthForFrame(f->seq);
      for (int e = 0; e < 2; ++e) {
        EXPECT_LT(std::abs(r.residual_px[e].x()), 4.0) << at;
        EXPECT_LT(std::abs(r.residual_px[e].y()), 4.0) << at;
        for (int servo : {models::kPanServo[e], models::kTiltServo[e]}) {
          EXPECT_EQ(r.final_pwm_us[servo] % 5, 0) << at << " " << models::kServoNames[servo];
          const int approach = sent.size() >= 2 && sent[sent.size() - 2][servo] > r.final_pwm_us[servo] ? -1 : 1;
          const double want = truth.ServoAngle(servo, r.final_pwm_us[servo], approach);
          const double got = servo == models::kPanServo[e] ? ft.angles[e].pan_rad[e] : ft.angles[e].tilt_rad[e];
          EXPECT_NEAR(got * 180 / M_PI, want * 180 / M_PI, 0.01) << at << " " << models::kServoNames[servo];
        }
      }
      std::cout << at << ": " << r.message << "; residual L " << r.residual_px[0].transpose() << " R "
                << r.residual_px[1].transpose() << "\n";
    }
  }
}

// The vergence protocol on each robot, ranged with the TRUE head (a perfect calibration) at the
// recorded commands and approaches: only what the servos applied can make it miss.
void ExpectVergenceWithinOnePercent(const char* file) {
  {
    const sim::VirtualOwlOptions vo = RobotOptions(file);
    sim::VirtualOwl owl(vo);
    const std::vector<Protocol> p = {
        LoadProtocolFile(std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/vergence_short.yaml")};
    RunOptions o;
    o.out_dir = testing::TempDir(std::string("resolution_vergence_") + std::filesystem::path(file).stem().string());
    o.robot_spec = "sim";
    std::ostringstream progress;
    o.progress = &progress;
    const RunSummary summary = RunProtocols(p, owl, o);
    ASSERT_EQ(summary.status, "complete") << summary.message;
    const models::HeadModel head = owl.TruthHeadModel();
    const auto placements = ReadPlacementsCsv(o.out_dir);
    std::vector<evaluation::Fixation> fixations;
    const double cx = (owl.Config().image_width - 1) / 2.0, cy = (owl.Config().image_height - 1) / 2.0;
    for (const FixationRow& row : ReadFixationsCsv(o.out_dir)) {
      evaluation::Fixation f;
      f.index = int(fixations.size());
      f.status = row.status.value_or(calib::TrialStatus::kFailed);
      f.reason = row.reason;
      f.pwm_us = row.pwm_us;
      f.approach = row.approach;
      for (int e = 0; e < 2; ++e)
        if (row.found[e] && row.offset_px[e]) f.target_px[e] = Eigen::Vector2d(cx, cy) + *row.offset_px[e];
      const double neck = head.ServoAngle(models::kNeck, f.pwm_us[models::kNeck]);
      const Eigen::Vector3d mid = models::HeadFromBase(neck).Inverse() *
                                  (0.5 * (head.geometry.centre_in_head[0] + head.geometry.centre_in_head[1]));
      for (const auto& pl : placements)
        if (pl.placement_index == row.placement_index)
          f.true_distance_m = (pl.base_from_target.translation() - mid).norm();
      fixations.push_back(f);
    }
    ASSERT_EQ(fixations.size(), 5u) << file;
    const evaluation::RangingEvaluation ev =
        evaluation::EvaluateRanging(head, fitting::NamedCovariance{}, owl.Config(), fixations, {}, {});
    // Variant A's 2 m fixation locks onto something 12 deg below the disc and loses it when seated:
    // a lost-target row (named in the notes), never a range. Every other fixation is ranged.
    const bool variant_a = std::string(file).find("variant_a") != std::string::npos;
    EXPECT_GE(ev.num_ok, variant_a ? 4 : 5) << file;
    for (const auto& n : ev.notes) std::cout << file << ": " << n << "\n";
    for (const evaluation::RangingRow& row : ev.rows)
      if (row.ok) {
        EXPECT_LT(std::abs(row.rel_error), 0.01) << file << " at " << row.true_m << " m";
      }
    EXPECT_LT(ev.rms_rel_error, 0.01) << file;
    std::cout << file << ": " << ev.num_ok << " ok of " << ev.rows.size() << ", RMS " << 100 * ev.rms_rel_error
              << " %, max " << 100 * ev.max_abs_rel_error << " %\n";
    std::filesystem::remove_all(o.out_dir);
  }
}

TEST(ResolutionRobots, FixationSettlesOnAPulseTheServoAppliesStep5) { ExpectFixationOnAppliedPulses(kStep5); }
TEST(ResolutionRobots, FixationSettlesOnAPulseTheServoAppliesDeadBand) { ExpectFixationOnAppliedPulses(kDeadBand); }
TEST(ResolutionRobots, FixationSettlesOnAPulseTheServoAppliesVariantA) { ExpectFixationOnAppliedPulses(kVariantA); }
TEST(ResolutionRobots, VergenceRangesWithinOnePercentWithTheTrueHeadStep5) { ExpectVergenceWithinOnePercent(kStep5); }
TEST(ResolutionRobots, VergenceRangesWithinOnePercentWithTheTrueHeadDeadBand) {
  ExpectVergenceWithinOnePercent(kDeadBand);
}
TEST(ResolutionRobots, VergenceRangesWithinOnePercentWithTheTrueHeadVariantA) {
  ExpectVergenceWithinOnePercent(kVariantA);
}

}  // namespace
}  // namespace owlcal::protocols
