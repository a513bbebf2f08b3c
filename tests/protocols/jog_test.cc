// The jog engine on the in-process virtual Owl: steps never pass the file's limits, widening is
// explicit and stops where the images show the end-stop (within the virtual Owl's true stop),
// and only confirmed or image-found ends reach the result.
#include <unistd.h>

#include <filesystem>

#include <gtest/gtest.h>

#include "protocols/jog.h"
#include "protocols/limits_revalidation.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {

struct JogFixture {
  sim::RobotTruth truth = sim::DefaultRobotTruth();
  JogOptions options;
  std::unique_ptr<robot::RobotInterface> owl;
  std::unique_ptr<JogSession> jog;
  JogFixture() {
    // The virtual Owl whose server accepts the jog's envelope (as owlcal jog makes it).
    sim::VirtualOwlOptions vo;
    sim::RobotTruth t = truth;
    t.robot = MakeJogRobotConfig(truth.robot, options);
    vo.truth = t;
    owl = std::make_unique<sim::VirtualOwl>(vo);
    RunOptions ro;  // the limits protocol's scene: a plain textured wall
    ro.out_dir = (std::filesystem::temp_directory_path() / ("owlcal_jog_scene_" + std::to_string(::getpid()))).string();
    std::filesystem::remove_all(ro.out_dir);
    const RunSummary s = SetUpLimitsScene(*owl, ro);
    EXPECT_EQ(s.status, "complete") << s.message;
    std::filesystem::remove_all(ro.out_dir);
    jog = std::make_unique<JogSession>(*owl, truth.robot, options, nullptr);
    jog->Start();
  }
};

TEST(JogSession, StepsNeverPassTheFileLimitsWithoutTheWidenKey) {
  JogFixture f;
  f.jog->Select(models::kRx);
  f.jog->GoToLimit(+1);
  for (int i = 0; i < 3; ++i) EXPECT_NE(f.jog->Step(+1).find("not moved"), std::string::npos);
  EXPECT_EQ(f.jog->Pose()[models::kRx], 1890);
  f.jog->GoToLimit(-1);
  EXPECT_EQ(f.jog->Pose()[models::kRx], 1200);
  f.jog->Step(-1);
  EXPECT_EQ(f.jog->Pose()[models::kRx], 1200);
  for (const models::PwmVector& p : f.jog->Sent())
    for (int s = 0; s < models::kNumServos; ++s) {
      EXPECT_GE(p[s], f.truth.robot.servos[s].min_us);
      EXPECT_LE(p[s], f.truth.robot.servos[s].max_us);
    }
  // A step toward a limit closer than one step stops at the limit.
  f.jog->Centre();
  f.jog->Select(models::kNeck);
  for (int i = 0; i < 200; ++i) f.jog->Step(+1);
  EXPECT_EQ(f.jog->Pose()[models::kNeck], 1950);
}

TEST(JogSession, AutoWidenStopsAtTheEndStopTheImagesShow) {
  JogFixture f;
  f.jog->Select(models::kNeck);
  const std::string what = f.jog->WidenAuto(+1);
  const JogEnd& e = f.jog->End(models::kNeck, +1);
  // 1960 us, 10 us beyond the file, at the middle of the backlash band: approached from below
  // (a widening) the servo meets it half the band later.
  const double stop = f.truth.servos[models::kNeck].endstop_hi_us + f.truth.servos[models::kNeck].hysteresis_us / 2;
  ASSERT_EQ(e.how, "end-stop") << what;
  EXPECT_LE(e.limit_us, stop) << what;  // never a limit past the physical stop
  EXPECT_GE(e.limit_us, stop - 6) << what;
  EXPECT_EQ(f.jog->Pose()[models::kNeck], e.limit_us);  // back off the stop
  int highest = 0;
  for (const models::PwmVector& p : f.jog->Sent()) highest = std::max(highest, p[models::kNeck]);
  EXPECT_LE(highest, stop + 20);  // the widening overshoots the stop by a few small steps only
  // Stopped: a further widen is refused.
  EXPECT_NE(f.jog->Widen(+1).find("not widened further"), std::string::npos);

  // Result: the found end, and a widened but unconfirmed end kept at the file's value.
  f.jog->GoToLimit(-1);
  f.jog->Widen(-1);
  EXPECT_EQ(f.jog->End(models::kNeck, -1).how, "widened");
  std::vector<std::string> notes;
  models::RobotConfig r = f.jog->Result(&notes);
  EXPECT_EQ(r.servos[models::kNeck].max_us, e.limit_us);
  EXPECT_EQ(r.servos[models::kNeck].min_us, 1100);
  ASSERT_EQ(notes.size(), 1u);
  EXPECT_NE(notes[0].find("Neck min widened to 1095 us but not confirmed"), std::string::npos) << notes[0];
  f.jog->Confirm();
  r = f.jog->Result(nullptr);
  EXPECT_EQ(r.servos[models::kNeck].min_us, 1095);
}

TEST(JogSession, RimAtTheLimitIsNotWidenedAndAutoNarrowsToIt) {
  JogFixture f;  // the default virtual Owl's Rx sees the socket rim well inside 1890 us
  f.jog->Select(models::kRx);
  const std::string once = f.jog->Widen(+1);
  EXPECT_NE(once.find("rim already shows at the limit 1890 us"), std::string::npos) << once;
  EXPECT_EQ(f.jog->End(models::kRx, +1).limit_us, 1890);
  int highest = 0;
  for (const models::PwmVector& p : f.jog->Sent()) highest = std::max(highest, p[models::kRx]);
  EXPECT_EQ(highest, 1890);  // nothing past the limit
  const std::string what = f.jog->WidenAuto(+1);
  const JogEnd& e = f.jog->End(models::kRx, +1);
  EXPECT_EQ(e.how, "rim") << what;
  EXPECT_LT(e.limit_us, 1890);
  EXPECT_GT(e.limit_us, 1700) << what;
  // One step further out the rim shows; at the limit it does not.
  f.jog->Step(+1);
  EXPECT_EQ(f.jog->Pose()[models::kRx], e.limit_us);  // a step past the image-found limit is refused
}

TEST(JogSession, RefusesARobotThatClampsToTheFileLimits) {
  const sim::RobotTruth truth = sim::DefaultRobotTruth();
  std::unique_ptr<robot::RobotInterface> owl = std::make_unique<sim::VirtualOwl>(sim::VirtualOwlOptions{});
  EXPECT_THROW(JogSession(*owl, truth.robot, JogOptions{}, nullptr), std::invalid_argument);
  JogOptions bad;
  bad.widen_step_us = 50;
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
}

}  // namespace
}  // namespace owlcal::protocols
