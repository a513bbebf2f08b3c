// The Pi server's clamp constants of the guide's robot reproduce the guide's own code
// snippets 4 (Python) and 5 (C), end names by direction included.
#include <gtest/gtest.h>

#include "robot/server_clamp_constants.h"

namespace owlcal::robot {
namespace {

TEST(ServerClampConstants, GuideRobotGivesTheGuideSnippets) {
  const models::RobotConfig g = models::DefaultRobotConfig();
  const std::string py = PythonServerClamp(g);
  for (const char* s : {"if (Ry>2000):\n    Ry = 2000\n",
                        "if (Ry<1120):\n    Ry = 1120\n",
                        "if (Rx>1890):\n    Rx = 1890\n",
                        "if (Rx<1200):\n    Rx = 1200\n",
                        "if (Ly>2000):\n    Ly = 2000\n",
                        "if (Ly<1180):\n    Ly = 1180\n",
                        "if (Lx>1850):\n    Lx = 1850\n",
                        "if (Lx<1180):\n    Lx = 1180\n",
                        "if (Neck>1950):\n    Neck = 1950\n",
                        "if (Neck<1100):\n    Neck = 1100\n"})
    EXPECT_NE(py.find(s), std::string::npos) << s;
  const std::string c = CServerRanges(g);
  for (const char* s : {"int RyB = 1120; // (bottom) to",
                        "int RyT = 2000; // (top)",
                        "int RxR = 1890; // (right) to",
                        "int RxL = 1200; // (left)",
                        "int LyB = 2000; // (bottom) to",
                        "int LyT = 1180; // (top)",
                        "int LxR = 1850; // (right) to",
                        "int LxL = 1180; // (left)",
                        "int NeckR = 1100;",
                        "int NeckL = 1950;",
                        "int RxC=1545;",
                        "int RyC=1530;",
                        "int LxC=1545;",
                        "int LyC=1580;",
                        "int NeckC = 1530;",
                        "int LyRange=LyT-LyB; // reflected so negative"})
    EXPECT_NE(c.find(s), std::string::npos) << s;
}

TEST(ServerClampConstants, EndsFollowTheDirection) {
  models::RobotConfig g = models::DefaultRobotConfig();
  g.servos[models::kRx].direction = -1;  // a robot whose Rx turns left with PWM
  EXPECT_EQ(ServoEndUs(g, models::kRx, true), 1200);
  EXPECT_NE(CServerRanges(g).find("int RxR = 1200;"), std::string::npos);
}

}  // namespace
}  // namespace owlcal::robot
