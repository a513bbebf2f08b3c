// Protocol files: parsing, error messages naming file/step/field, pose expressions, plans.
#include <gtest/gtest.h>

#include "protocols/protocol.h"
#include "protocols/step_plan.h"

namespace owlcal::protocols {
namespace {

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseProtocolYaml(yaml, "p.yaml");
  } catch (const ProtocolError& e) {
    return e.what();
  }
  return "";
}

TEST(PwmExpr, ParsesNumbersAndRobotRelativeValues) {
  const models::ServoConfig rx = models::DefaultRobotConfig().servos[models::kRx];
  EXPECT_EQ(ParsePwmExpr("1600")->Resolve(rx), 1600);
  EXPECT_EQ(ParsePwmExpr("centre")->Resolve(rx), 1545);
  EXPECT_EQ(ParsePwmExpr("center-45")->Resolve(rx), 1500);
  EXPECT_EQ(ParsePwmExpr("max-10")->Resolve(rx), 1880);
  EXPECT_EQ(ParsePwmExpr(" min + 5 ")->Resolve(rx), 1205);
  EXPECT_FALSE(ParsePwmExpr("centre*2"));
  EXPECT_FALSE(ParsePwmExpr("abc"));
  EXPECT_FALSE(ParsePwmExpr("-5"));
  EXPECT_FALSE(ParsePwmExpr(""));
}

TEST(Protocol, ParsesEveryStepKindAndExpandsRepeat) {
  const Protocol p = ParseProtocolYaml(R"(
name: all
target: chessboard
targets:
  chessboard: {target_type: chessboard, cols: 9, rows: 6, square_size_m: 0.026}
steps:
  - move-to: {pose: {Rx: centre+10, Neck: 1500}}
  - sweep: {servo: Lx, from: centre-40, to: centre+40, step_us: 20}
  - grid: {eyes: left, pan_us: [-10, 10], tilt_us: [5]}
  - place-target: {target: chessboard, distance_m: 0.7, rpy_deg: [0, 10, 0]}
  - capture: {frames: 2, settle: {mode: time, time_ms: 50}}
  - fixate: {eyes: right, gain: 0.2}
  - step-response: {amplitudes_deg: [5], gains: [0.1, 0.3]}
  - limits: {servos: [Rx, neck], coarse_us: 10, fine_us: 1}
  - alignment: {frames: 1}
  - latency: {servo: Ry}
  - repeat: {times: 2, steps: [{wait: {ms: 5}}, {capture: {frames: 1}}]}
)",
                                       "all.yaml");
  EXPECT_EQ(p.name, "all");
  ASSERT_EQ(p.steps.size(), 14u);
  EXPECT_EQ(p.steps[0].kind(), StepKind::kMoveTo);
  EXPECT_EQ(p.steps[0].As<MoveToStep>().pose.Resolve(models::DefaultRobotConfig())[models::kRx], 1555);
  EXPECT_EQ(p.steps[0].As<MoveToStep>().pose.Resolve(models::DefaultRobotConfig())[models::kLy], 1580);
  EXPECT_EQ(p.steps[1].As<SweepStep>().servo, models::kLx);
  EXPECT_EQ(p.steps[2].As<GridStep>().eyes, EyeSet::kLeft);
  EXPECT_EQ(p.steps[4].As<CaptureStep>().settle.mode, SettleRule::Mode::kTime);
  EXPECT_DOUBLE_EQ(p.steps[5].As<FixateStep>().gain, 0.2);
  EXPECT_EQ(p.steps[5].As<FixateStep>().eyes, EyeSet::kRight);
  EXPECT_EQ(p.steps[6].As<StepResponseStep>().eye, models::kRightEye);
  EXPECT_EQ(p.steps[6].As<StepResponseStep>().axis, Axis::kPan);
  EXPECT_EQ(p.steps[7].As<LimitsStep>().servos, (std::vector<int>{models::kRx, models::kNeck}));
  EXPECT_EQ(p.steps[9].As<LatencyStep>().servo, models::kRy);
  EXPECT_EQ(p.steps[10].kind(), StepKind::kWait);
  EXPECT_EQ(p.steps[10].As<WaitStep>().ms, 5);
  EXPECT_THROW(p.steps[10].As<CaptureStep>(), std::bad_variant_access);
  for (const Step& s : p.steps) EXPECT_EQ(s.Detects(), false) << s.name;
  // Each step knows its line: the 11 listed steps are on lines 7..17, a repeat's on its line.
  EXPECT_EQ(p.steps[0].file_line, 7);
  EXPECT_EQ(p.steps[9].file_line, 16);
  EXPECT_EQ(p.steps[9].Where(), "all.yaml:16: step 9 (latency)");
  EXPECT_EQ(p.steps[13].name, "capture13#2");
  EXPECT_EQ(p.targets.at("chessboard").cols, 9);
}

TEST(Protocol, ErrorsNameFileStepAndField) {
  std::string e = ErrorOf("name: x\nsteps:\n  - capture: {frames: 1}\n  - sweep: {servo: Rx, step_us: -5}\n");
  EXPECT_NE(e.find("p.yaml:4: step 1 (sweep): field 'step_us'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - sweep: {servo: Qx}\n");
  EXPECT_NE(e.find("step 0 (sweep): field 'servo': 'Qx'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - move-to: {pose: {Rx: centre*3}}\n");
  EXPECT_NE(e.find("step 0 (move-to) pose: field 'Rx'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - capture: {frames: 1, colour: red}\n");
  EXPECT_NE(e.find("unknown field 'colour'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - jump: {}\n");
  EXPECT_NE(e.find("p.yaml:3: step 0 (jump): unknown step kind 'jump'"), std::string::npos) << e;
  // A field on its own line is named with that line; an enum names the values it takes.
  e = ErrorOf("name: x\nsteps:\n  - grid:\n      frames: 1\n      eyes: three\n");
  EXPECT_NE(e.find("p.yaml:5: step 0 (grid): field 'eyes': 'three' is not one of both, left, right"), std::string::npos)
      << e;
  e = ErrorOf("name: x\nsteps:\n  - step-response: {axis: roll}\n");
  EXPECT_NE(e.find("field 'axis': 'roll' is not one of pan, tilt"), std::string::npos) << e;
  e = ErrorOf("steps: []\n");
  EXPECT_NE(e.find("field 'name'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - step-response: {gains: [0.1, -1]}\n");
  EXPECT_NE(e.find("field 'gains'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps: [\n");
  EXPECT_NE(e.find("not valid YAML"), std::string::npos) << e;
}

// Regression: a repeat of 2e9, or three nested repeats of 1000, ended in a bare std::bad_alloc.
TEST(Protocol, TagTargetsAreAprilGridsOfTargets) {
  const std::string head =
      "name: x\ntarget: board\ntargets:\n  board: {target_type: chessboard}\n"
      "  sheet: {target_type: aprilgrid, tagCols: 6, tagRows: 2, first_id: 100}\n";
  const Protocol p = ParseProtocolYaml(head + "tag_targets: [sheet]\nsteps: []\n", "t.yaml");
  ASSERT_EQ(p.tag_targets.size(), 1u);
  EXPECT_EQ(p.tag_targets[0], "sheet");
  EXPECT_EQ(p.targets.at("sheet").first_id, 100);
  std::string e = ErrorOf(head + "tag_targets: [other]\nsteps: []\n");
  EXPECT_NE(e.find("tag_targets"), std::string::npos) << e;
  EXPECT_NE(e.find("'other' is not one of `targets`"), std::string::npos) << e;
  e = ErrorOf(head + "tag_targets: [board]\nsteps: []\n");
  EXPECT_NE(e.find("'board' is not an aprilgrid"), std::string::npos) << e;
  e = ErrorOf(head + "tag_targets: [sheet, sheet]\nsteps: []\n");
  EXPECT_NE(e.find("listed twice"), std::string::npos) << e;
  e = ErrorOf(head + "tag_targets: sheet\nsteps: []\n");
  EXPECT_NE(e.find("expected a list"), std::string::npos) << e;
}

TEST(Protocol, PlanSizeIsCappedWithAClearError) {
  std::string e = ErrorOf("name: x\nsteps:\n  - repeat: {times: 2000000000, steps: [{wait: {ms: 1}}]}\n");
  EXPECT_NE(e.find("p.yaml:3: step 0 (repeat): field 'times'"), std::string::npos) << e;
  e = ErrorOf("name: x\nsteps:\n  - repeat: {times: 1000, steps: [{wait: {ms: 1}}]}\n");
  EXPECT_EQ(e, "");  // 1000 steps is fine
  e = ErrorOf(
      "name: x\nsteps:\n  - repeat: {times: 1000, steps: [{repeat: {times: 1000, steps: [{repeat: {times: 1000, steps: "
      "[{capture: {frames: 1}}]}}]}}]}\n");
  EXPECT_NE(e.find("field 'times'"), std::string::npos) << e;
  EXPECT_NE(e.find("longer than 10000 steps"), std::string::npos) << e;
  // Several repeats that each fit but together do not.
  std::string many = "name: x\nsteps:\n";
  for (int i = 0; i < 3; ++i) many += "  - repeat: {times: 4000, steps: [{wait: {ms: 1}}]}\n";
  e = ErrorOf(many);
  EXPECT_NE(e.find("step 2 (repeat): field 'times'"), std::string::npos) << e;
}

// Regression: step_us, pan_us or amplitude_us of 2147483647 overflowed a signed int and the sweep
// ran 2,400 commands clamped to the opposite end. Pulse widths are bounded when read and
// checked against the robot file's range before anything moves.
TEST(Protocol, PulseWidthQuantitiesCannotOverflow) {
  for (const char* yaml : {"  - sweep: {servo: Rx, step_us: 2147483647}\n",
                           "  - grid: {pan_us: [0, 2147483647]}\n",
                           "  - latency: {servo: Rx, amplitude_us: 2147483647}\n",
                           "  - limits: {coarse_us: 2147483647}\n",
                           "  - grid: {tilt_us: [-99999]}\n",
                           "  - fixate: {max_step_us: 10000}\n"}) {
    const std::string e = ErrorOf(std::string("name: x\nsteps:\n") + yaml);
    EXPECT_NE(e.find("p.yaml:3: step 0"), std::string::npos) << yaml << " -> " << e;
    EXPECT_NE(e.find("_us'"), std::string::npos) << yaml << " -> " << e;
  }
  // Strict numbers: hex, nan and fractions are not integers.
  EXPECT_NE(ErrorOf("name: x\nsteps:\n  - sweep: {servo: Rx, step_us: 0x10}\n").find("'0x10' is not an integer"),
            std::string::npos);
  EXPECT_NE(ErrorOf("name: x\nsteps:\n  - fixate: {gain: .nan}\n").find("field 'gain'"), std::string::npos);
  EXPECT_NE(ErrorOf("name: x\nsteps:\n  - place-target: {target: b, distance_m: 1e300}\n").find("field 'distance_m'"),
            std::string::npos);
  // Within the packet's range but larger than the robot's: refused against the robot file.
  const Protocol p = ParseProtocolYaml("name: x\nsteps:\n  - sweep: {servo: Rx, step_us: 5000}\n", "p.yaml");
  const models::RobotConfig robot = models::DefaultRobotConfig();
  const std::string why = CheckStepForRobot(p.steps[0], robot);
  EXPECT_NE(why.find("p.yaml:3: step 0 (sweep): field 'step_us': 5000 us is more than Rx's range of"),
            std::string::npos)
      << why;
  const Protocol ok = ParseProtocolYaml("name: x\nsteps:\n  - sweep: {servo: Rx, step_us: 25}\n", "p.yaml");
  EXPECT_EQ(CheckStepForRobot(ok.steps[0], robot), "");
  const Protocol lat = ParseProtocolYaml("name: x\nsteps:\n  - latency: {servo: Neck, amplitude_us: 9000}\n", "p.yaml");
  EXPECT_NE(CheckStepForRobot(lat.steps[0], robot).find("field 'amplitude_us'"), std::string::npos);
}

TEST(Protocol, EveryStandardProtocolLoads) {
  for (const std::string& name : StandardProtocolNames()) {
    const Protocol p = LoadProtocolFile(ResolveProtocolPath(name));
    EXPECT_EQ(p.name, name);
    EXPECT_FALSE(p.steps.empty()) << name;
    EXPECT_FALSE(p.target.empty()) << name;
  }
  EXPECT_THROW(ResolveProtocolPath("no_such_protocol"), ProtocolError);
}

TEST(StepPlan, SweepPreApproachesAndReturns) {
  const Protocol p =
      ParseProtocolYaml("name: s\nsteps:\n  - sweep: {servo: Rx, from: 1500, to: 1560, step_us: 30}\n", "s");
  const auto poses = PlanPoses(p.steps[0].As<SweepStep>(), models::DefaultRobotConfig());
  std::vector<int> rx;
  std::vector<bool> cap;
  for (const auto& pp : poses) {
    rx.push_back(pp.pwm_us[models::kRx]);
    cap.push_back(pp.capture);
  }
  EXPECT_EQ(rx, (std::vector<int>{1470, 1500, 1530, 1560, 1590, 1560, 1530, 1500}));
  EXPECT_EQ(cap, (std::vector<bool>{false, true, true, true, false, true, true, true}));
  EXPECT_EQ(poses[0].pwm_us[models::kLy], 1580);  // other servos at centre
}

TEST(StepPlan, GridOffsetsFollowServoDirections) {
  const Protocol p = ParseProtocolYaml("name: g\nsteps:\n  - grid: {pan_us: [0], tilt_us: [50]}\n", "g");
  const auto poses = PlanPoses(p.steps[0].As<GridStep>(), models::DefaultRobotConfig());
  ASSERT_EQ(poses.size(), 1u);
  EXPECT_EQ(poses[0].pwm_us[models::kRy], 1580);  // up = +PWM on Ry
  EXPECT_EQ(poses[0].pwm_us[models::kLy], 1530);  // up = -PWM on the mirrored Ly
}

TEST(StepPlan, PlacementCentresTheBoard) {
  const Protocol p = ParseProtocolYaml(
      "name: g\ntargets:\n  b: {target_type: chessboard, cols: 9, rows: 6, square_size_m: 0.02}\n"
      "steps:\n  - place-target: {target: b, distance_m: 0.5}\n",
      "g");
  const calib::TargetDefinition& def = p.targets.at("b");
  const Eigen::Isometry3d pose = PlacementPose(p.steps[0].As<PlaceTargetStep>(), &def);
  const Eigen::Vector4d e = def.Extent();
  const Eigen::Vector3d centre = pose * Eigen::Vector3d((e[0] + e[1]) / 2, (e[2] + e[3]) / 2, 0);
  EXPECT_NEAR(centre.x(), 0, 1e-12);
  EXPECT_NEAR(centre.y(), 0, 1e-12);
  EXPECT_NEAR(centre.z(), 0.5, 1e-12);
  EXPECT_NE(PlacementPrompt(p, p.steps[0].As<PlaceTargetStep>()).find("500 mm in front of the neck axis"),
            std::string::npos);
}

}  // namespace
}  // namespace owlcal::protocols
