// Closed-loop fixation on the virtual Owl: converges at the course gain 0.1, a divergent gain
// is stopped before any limit; the fixation detector finds the rendered disc.
#include <gtest/gtest.h>

#include "models/head_model.h"
#include "protocols/fixation.h"
#include "protocols/step_plan.h"
#include "robot/limits_guard.h"
#include "sim/robot_prior.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {

struct Rig {
  Rig() = default;
  explicit Rig(const sim::VirtualOwlOptions& o) : owl(o) {}
  sim::VirtualOwl owl{sim::VirtualOwlOptions{}};
  robot::LimitsGuard guard{owl.Config()};
  models::PwmVector cmd = owl.Config().Centre();
  std::vector<models::PwmVector> sent;
  int64_t last = -1;
  FixationIo Io() {
    FixationIo io;
    io.command = [this] { return cmd; };
    io.send = [this](const models::PwmVector& p) {
      cmd = guard.Clamp(p).pwm_us;
      sent.push_back(cmd);
      owl.SendServos(cmd);
    };
    io.grab = [this] {
      auto f = owl.GrabFrame(last, 1'000'000'000);
      last = f->stamp_ns;
      return *f;
    };
    return io;
  }
  void PlaceFixation(double distance_m, double x_m = 0) {
    PlaceTargetStep s;
    s.target = "fixation";
    s.distance_m = distance_m;
    s.offset_m = Eigen::Vector2d(x_m, 0);
    owl.SetTargetPose("fixation", PlacementPose(s, nullptr));
    for (const std::string& n : owl.TargetNames())
      if (n != "fixation") owl.SetTargetPose(n, HiddenPose());
    owl.SendServos(cmd);
    owl.SleepNs(300'000'000);
  }
};

TEST(FixationDetector, FindsTheRenderedDiscWithSubpixelAccuracy) {
  Rig rig;
  rig.PlaceFixation(0.8, 0.05);
  auto f = rig.owl.GrabFrame(rig.owl.NowNs(), 1'000'000'000);
  ASSERT_TRUE(f);
  const models::HeadModel head = rig.owl.TruthHeadModel();
  const sim::FrameTruth truth = rig.owl.TruthForFrame(f->seq);
  for (int e = 0; e < 2; ++e) {
    Eigen::Vector2d expected;
    ASSERT_TRUE(head.Project(models::Eye(e), truth.angles[e], Eigen::Vector3d(0.05, 0, 0.8), &expected));
    const calib::FixationDetection d = calib::DetectFixationTarget(e == 0 ? f->left : f->right, {});
    ASSERT_TRUE(d.found) << d.message;
    std::cout << models::kEyeNames[e] << ": detected " << d.centre.transpose() << " truth " << expected.transpose()
              << " error " << (d.centre - expected).norm() << " px\n";
    EXPECT_LT((d.centre - expected).norm(), 0.5);
  }
}

TEST(Fixation, ConvergesAtTheCourseGain) {
  for (double distance : {0.25, 0.5, 1.0, 2.0}) {
    Rig rig;
    rig.PlaceFixation(distance, 0.03);
    FixationOptions o;
    o.gain = 0.1;
    o.max_iterations = 150;
    auto loc = MakeFixationLocator();
    const FixationResult r = RunFixation(o, rig.owl.Config(), *loc, rig.Io());
    EXPECT_EQ(r.outcome, FixationResult::Outcome::kConverged) << "distance " << distance << ": " << r.message;
    EXPECT_TRUE(r.seated);
    // Seated on the 5 us grid (protocols/fixation.h): within half a grid step per axis (2.9 px at
    // 1.15 px/us) plus noise.
    for (int e = 0; e < 2; ++e) {
      EXPECT_LT(std::abs(r.residual_px[e].x()), 3.2) << "distance " << distance;
      EXPECT_LT(std::abs(r.residual_px[e].y()), 3.2) << "distance " << distance;
    }
    std::cout << "distance " << distance << ": " << OutcomeName(r.outcome) << " in " << r.iterations
              << " frames, residual L " << r.residual_px[0].transpose() << " R " << r.residual_px[1].transpose()
              << "\n";
  }
}

// A servo with 5 us PWM steps and a 3 us dead band moves the image ~6 px at a time: a 1 px
// tolerance can never be met, and the loop used to cycle between two pulses until it ran out of
// frames. It now widens the axis' dead zone to what the servo resolves, and converges.
TEST(Fixation, ConvergesOnFiveMicrosecondPwmSteps) {
  sim::VirtualOwlOptions vo;
  sim::RobotTruth t = sim::DefaultRobotTruth();
  for (auto& sv : t.servos) {
    sv.quantum_us = 5;
    sv.dead_band_us = 3;
  }
  vo.truth = t;
  for (double distance : {0.5, 1.5}) {
    Rig rig(vo);
    rig.PlaceFixation(distance, 0.03);
    FixationOptions o;
    o.gain = 0.1;
    o.max_iterations = 150;
    auto loc = MakeFixationLocator();
    const FixationResult r = RunFixation(o, rig.owl.Config(), *loc, rig.Io());
    std::string reason;
    EXPECT_EQ(FixationStatus(r, o, &reason), calib::TrialStatus::kOk) << "distance " << distance << ": " << reason;
    // Within one 5 us step's image shift (5.75 px at 1.15 px/us) on each axis: the loop stops on
    // whichever side of the target the servo's step left it (ranging uses the target's pixel).
    for (int e = 0; e < 2; ++e) {
      EXPECT_LT(std::abs(r.residual_px[e].x()), 6.0) << "distance " << distance;
      EXPECT_LT(std::abs(r.residual_px[e].y()), 6.0) << "distance " << distance;
    }
    // Seated: every controlled servo's command is on the 5 us grid, and the servo applies exactly
    // it (the truth's joint angles are the truth maps at the command with the seating approach).
    ASSERT_TRUE(r.seated);
    const models::HeadModel truth = rig.owl.TruthHeadModel();
    auto f = rig.owl.GrabFrame(rig.last, 1'000'000'000);
    const sim::FrameTruth ft = rig.owl.TruthForFrame(f->seq);
    for (int e = 0; e < 2; ++e) {
      for (int servo : {models::kPanServo[e], models::kTiltServo[e]}) {
        EXPECT_EQ(r.final_pwm_us[servo] % 5, 0) << models::kServoNames[servo];
        const int approach =
            rig.sent.size() >= 2 && rig.sent[rig.sent.size() - 2][servo] > r.final_pwm_us[servo] ? -1 : 1;
        const double want = truth.ServoAngle(servo, r.final_pwm_us[servo], approach);
        const double got = servo == models::kPanServo[e] ? ft.angles[e].pan_rad[e] : ft.angles[e].tilt_rad[e];
        EXPECT_NEAR(got, want, 1e-4) << models::kServoNames[servo] << " distance " << distance;
      }
    }
    std::cout << "5 us steps, distance " << distance << ": " << r.message << "\n";
    if (getenv("TRACE"))
      for (const auto& fs : r.trace)
        std::cout << fs.k << " L " << fs.offset_px[0].transpose() << " R " << fs.offset_px[1].transpose() << " pwm "
                  << fs.pwm_us[0] << " " << fs.pwm_us[1] << " " << fs.pwm_us[2] << " " << fs.pwm_us[3] << "\n";
  }
}

// The target leaves the view: the fixation is a "lost target", never ok.
// A 24 mm disc at 2 m is 2.5-3.2 px in radius on real Owls' lenses (f 480-620 px) once blurred and
// thresholded: below the detector's default 3 px minimum, so the loop either lost it or locked onto
// a dark spot of the wall (7 of 8 robots of bench/ranging_population_bench). With the size the
// placement predicts (FixationDetectorOptions::size_hint_px) each eye fixates the disc itself:
// the true projection of the disc centre lies where the locator says, on robots drawn like the
// bench's (narrow and wide lenses, noisy streams, 1 and 5 us PWM steps).
TEST(Fixation, FarSmallDiscIsFixatedNotTheWall) {
  for (uint64_t seed : {1u, 2u, 6u}) {
    std::mt19937_64 rng(seed * 7919 + 17);
    sim::DrawnRobot robot = sim::DrawRobot(&rng, "population-" + std::to_string(seed));
    for (auto& s : robot.truth.servos) s.quantum_us = seed % 2 ? 5 : 1;
    sim::VirtualOwlOptions vo;
    vo.truth = robot.truth;
    vo.scene = robot.scene;
    vo.seed = seed;
    Rig rig(vo);
    const double distance = 2.0;
    rig.PlaceFixation(distance, 0.0);
    FixationOptions o;
    o.gain = 0.1;
    o.max_iterations = 200;
    o.focal_px = NominalFocalPx(rig.owl.Config());
    calib::FixationDetectorOptions d;
    d.size_hint_px = o.focal_px * 0.012 / distance;
    auto loc = MakeFixationLocator(d);
    const FixationResult r = RunFixation(o, rig.owl.Config(), *loc, rig.Io());
    ASSERT_EQ(r.outcome, FixationResult::Outcome::kConverged) << "seed " << seed << ": " << r.message;
    auto f = rig.owl.GrabFrame(rig.last, 1'000'000'000);
    ASSERT_TRUE(f);
    const models::HeadModel head = rig.owl.TruthHeadModel();
    const sim::FrameTruth truth = rig.owl.TruthForFrame(f->seq);
    for (int e = 0; e < 2; ++e) {
      Eigen::Vector2d disc;
      ASSERT_TRUE(head.Project(models::Eye(e), truth.angles[e], Eigen::Vector3d(0, 0, distance), &disc));
      const Eigen::Vector2d centre(319.5, 239.5);
      ASSERT_TRUE(r.radius_px[e]);
      std::cout << "seed " << seed << " " << models::kEyeNames[e] << ": disc " << (disc - centre).transpose()
                << " px from centre, locator " << r.residual_px[e].transpose() << ", radius " << *r.radius_px[e]
                << " px (hint " << d.size_hint_px << ")\n";
      // The eye looks at the disc (seated residual within the 5 us grid's 3 px), and what the
      // locator followed is the disc (its true projection within 1.5 px of the reported offset).
      EXPECT_LT((disc - centre).norm(), 4.5) << "seed " << seed << " eye " << e;
      EXPECT_LT((disc - centre - r.residual_px[e]).norm(), 1.5) << "seed " << seed << " eye " << e;
      EXPECT_GT(*r.radius_px[e], 0.6 * d.size_hint_px);
      EXPECT_LT(*r.radius_px[e], 1.4 * d.size_hint_px);
    }
  }
}

TEST(Fixation, LostTargetIsReportedAsSuch) {
  Rig rig;
  rig.PlaceFixation(1.0, 0.03);
  FixationOptions o;
  o.max_iterations = 60;
  // The target is found in the first frames, then never again (taken away mid-loop).
  struct VanishingLocator : TargetLocator {
    int calls = 0;
    std::optional<Eigen::Vector2d> Locate(const cv::Mat& img, int /*eye*/) override {
      if (++calls > 6) return std::nullopt;
      const calib::FixationDetection d = calib::DetectFixationTarget(img, {});
      return d.found ? std::optional(d.centre) : std::nullopt;
    }
    std::string Name() const override { return "vanishing"; }
  } loc;
  const FixationResult r = RunFixation(o, rig.owl.Config(), loc, rig.Io());
  std::string reason;
  EXPECT_EQ(FixationStatus(r, o, &reason), calib::TrialStatus::kLostTarget) << OutcomeName(r.outcome) << ": " << reason;
  EXPECT_NE(reason.find("not found"), std::string::npos) << reason;
}

TEST(Fixation, DivergentGainIsStoppedBeforeAnyLimit) {
  Rig rig;
  rig.PlaceFixation(1.0, 0.15);
  FixationOptions o;
  o.gain = 0.6;
  o.max_iterations = 200;
  o.eyes[0] = false;
  auto loc = MakeFixationLocator();
  const FixationResult r = RunFixation(o, rig.owl.Config(), *loc, rig.Io());
  std::cout << OutcomeName(r.outcome) << ": " << r.message << "\n";
  EXPECT_TRUE(r.outcome == FixationResult::Outcome::kDiverged || r.outcome == FixationResult::Outcome::kLimit)
      << OutcomeName(r.outcome);
  const models::RobotConfig& c = rig.owl.Config();
  for (const auto& p : rig.sent)
    for (int i = 0; i < models::kNumServos; ++i) {
      EXPECT_GT(p[i], c.servos[i].min_us + o.limit_margin_us - 1);
      EXPECT_LT(p[i], c.servos[i].max_us - o.limit_margin_us + 1);
    }
}

}  // namespace
}  // namespace owlcal::protocols

namespace owlcal::protocols {
namespace {

TEST(Fixation, ConvergesOnTheAprilGridCentre) {
  Rig rig;
  calib::TargetDefinition grid;
  grid.id = "aprilgrid";
  grid.kind = calib::TargetKind::kAprilGrid;
  grid.tag_cols = 6;
  grid.tag_rows = 6;
  grid.tag_size_m = 0.024;
  grid.tag_spacing = 0.3;
  PlaceTargetStep s;
  s.target = "aprilgrid";
  s.distance_m = 0.7;
  s.offset_m = Eigen::Vector2d(0.04, 0.02);
  rig.owl.SetTargetPose("aprilgrid", PlacementPose(s, &grid));
  for (const std::string& n : rig.owl.TargetNames())
    if (n != "aprilgrid") rig.owl.SetTargetPose(n, HiddenPose());
  rig.owl.SleepNs(300'000'000);
  FixationOptions o;
  o.gain = 0.1;
  o.max_iterations = 150;
  auto loc = MakeBoardLocator(grid);
  const FixationResult r = RunFixation(o, rig.owl.Config(), *loc, rig.Io());
  EXPECT_EQ(r.outcome, FixationResult::Outcome::kConverged) << r.message;
  // The board centre is on both optical axes: check against the truth projection.
  auto f = rig.owl.GrabFrame(rig.last, 1'000'000'000);
  const sim::FrameTruth t = rig.owl.TruthForFrame(f->seq);
  for (int e = 0; e < 2; ++e) {
    Eigen::Vector2d px;
    ASSERT_TRUE(rig.owl.TruthHeadModel().Project(models::Eye(e), t.angles[e], Eigen::Vector3d(0.04, 0.02, 0.7), &px));
    const models::CameraIntrinsics& k = rig.owl.Truth().intrinsics[e];
    const Eigen::Vector2d centre((k.width - 1) / 2.0, (k.height - 1) / 2.0);
    std::cout << models::kEyeNames[e] << " board centre at " << px.transpose() << ", image centre "
              << centre.transpose() << "\n";
    EXPECT_LT((px - centre).norm(), 4.5) << models::kEyeNames[e];  // seated: half a 5 us grid step per axis
  }
}

}  // namespace
}  // namespace owlcal::protocols
