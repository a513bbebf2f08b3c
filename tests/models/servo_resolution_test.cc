#include "models/servo_resolution.h"

#include <gtest/gtest.h>

namespace owlcal::models {
namespace {

TEST(ServoResolution, OneMicrosecondNoDeadBandAppliesEveryCommand) {
  const ServoResolution r;
  ServoState s{1500, 0};
  for (int u : {1501, 1499, 1500, 1600}) {
    const ServoState n = r.Next(s, u);
    EXPECT_EQ(n.applied_us, u);
    EXPECT_EQ(n.approach, u > s.applied_us ? 1 : -1);
    s = n;
  }
}

TEST(ServoResolution, RoundingGeneratorMatchesNearestMultiple) {
  for (int step : {2, 3, 4, 5, 10}) {
    const ServoResolution r = ServoResolution::Rounding(step, 1);
    for (int u = 1000; u < 1100; ++u) {
      EXPECT_EQ(r.Stepped(u), int(std::lround(double(u) / step)) * step) << "step " << step << " u " << u;
      EXPECT_EQ(r.Stepped(u) % step, 0);
    }
  }
}

TEST(ServoResolution, TruncatingGeneratorHasPhaseZero) {
  const ServoResolution r{5, 1, 0};
  EXPECT_EQ(r.Stepped(1545), 1545);
  EXPECT_EQ(r.Stepped(1549), 1545);
  EXPECT_EQ(r.Stepped(1550), 1550);
  EXPECT_EQ(r.Stepped(1544), 1540);
}

TEST(ServoResolution, DeadBandIgnoresSmallChangesAndKeepsApproach) {
  const ServoResolution r{1, 3, 0};
  ServoState s{1500, 1};
  s = r.Next(s, 1502);
  EXPECT_EQ(s, (ServoState{1500, 1}));
  s = r.Next(s, 1498);
  EXPECT_EQ(s, (ServoState{1500, 1}));
  s = r.Next(s, 1497);
  EXPECT_EQ(s, (ServoState{1497, -1}));
  s = r.Next(s, 1500);
  EXPECT_EQ(s, (ServoState{1500, 1}));
}

TEST(ServoResolution, GridCommandsAreAppliedExactlyWhateverThePhase) {
  for (int phase = 0; phase < 5; ++phase) {
    const ServoResolution r{5, 4, phase};
    ServoState s{1545, 1};
    for (int u : {1550, 1545, 1540, 1600, 1595}) {
      s = r.Next(s, u);
      EXPECT_EQ(s.applied_us, u) << "phase " << phase;
    }
  }
}

TEST(ServoResolution, SnapAndMinimumMove) {
  const ServoResolution r = ServoResolution::Rounding(5, 2);
  EXPECT_EQ(r.Snap(1547.4), 1545);
  EXPECT_EQ(r.Snap(1547.6), 1550);
  EXPECT_EQ(r.MinMoveUs(), 5);
  EXPECT_EQ((ServoResolution{1, 3, 0}).MinMoveUs(), 3);
  EXPECT_EQ((ServoResolution{5, 7, 0}).MinMoveUs(), 10);
  EXPECT_EQ(r.SnapInside(1893, 1200, 1892), 1890);
  EXPECT_EQ(r.SnapInside(1198, 1201, 1890), 1205);
  EXPECT_EQ(r.SnapInside(1201, 1201, 1203), 1201);  // no multiple of 5 inside: clamped
}

TEST(ServoResolution, CheckRejectsNonsense) {
  std::string why;
  EXPECT_TRUE((ServoResolution{5, 2, 3}).Check(&why));
  EXPECT_FALSE((ServoResolution{0, 1, 0}).Check(&why));
  EXPECT_FALSE((ServoResolution{5, 1, 5}).Check(&why));
  EXPECT_NE(why.find("phase"), std::string::npos);
}

}  // namespace
}  // namespace owlcal::models
