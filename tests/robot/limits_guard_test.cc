#include "robot/limits_guard.h"

#include <gtest/gtest.h>

#include <climits>
#include <random>
#include <string>
#include <vector>

#include "robot/packet_assembler.h"
#include "robot/packet_codec.h"

namespace owlcal::robot {
namespace {

using models::PwmVector;

TEST(LimitsGuard, ClampsEachServoToItsLimitsAndSaysWhich) {
  std::vector<std::string> log;
  LimitsGuard guard(models::DefaultRobotConfig(), [&](const std::string& line) { log.push_back(line); });
  const ClampResult ok = guard.Clamp({1545, 1530, 1545, 1580, 1530});
  EXPECT_FALSE(ok.any_clamped);
  EXPECT_TRUE(log.empty());
  const ClampResult c = guard.Clamp({2100, 1000, 1545, 1180, 9999});
  EXPECT_EQ(c.pwm_us, (PwmVector{1890, 1120, 1545, 1180, 1950}));
  EXPECT_TRUE(c.any_clamped);
  EXPECT_EQ(c.clamped, (std::array<bool, 5>{true, true, false, false, true}));
  ASSERT_EQ(log.size(), 1u);
  EXPECT_EQ(log[0],
            "limits guard: Rx = 2100 us clamped to 1890 (max_us), Ry = 1000 us clamped to 1120 (min_us), "
            "Neck = 9999 us clamped to 1950 (max_us)");
  EXPECT_EQ(c.message, log[0]);
  EXPECT_EQ(guard.NumClamped(), 1);
  EXPECT_TRUE(guard.WithinLimits(c.pwm_us));
  EXPECT_FALSE(guard.WithinLimits({2100, 1530, 1545, 1580, 1530}));
}

TEST(LimitsGuard, LimitsThemselvesPassUnchanged) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  LimitsGuard guard(robot);
  PwmVector lo, hi;
  for (int i = 0; i < models::kNumServos; ++i) {
    lo[i] = robot.servos[i].min_us;
    hi[i] = robot.servos[i].max_us;
  }
  EXPECT_FALSE(guard.Clamp(lo).any_clamped);
  EXPECT_FALSE(guard.Clamp(hi).any_clamped);
  lo[models::kLy] -= 1;
  EXPECT_TRUE(guard.Clamp(lo).clamped[models::kLy]);
}

TEST(LimitsGuard, RejectsInvertedLimits) {
  models::RobotConfig robot = models::DefaultRobotConfig();
  robot.servos[models::kLx].min_us = 1900;
  EXPECT_THROW(LimitsGuard{robot}, std::invalid_argument);
}

TEST(PacketAssembler, JoinsAnySplitIntoWholePackets) {
  const std::string stream = "1545 1530 1545 1580 15301600 1600 1600 1600 1600";
  for (size_t cut1 = 0; cut1 <= stream.size(); cut1 += 5) {
    for (size_t cut2 = cut1; cut2 <= stream.size(); cut2 += 7) {
      PacketAssembler a;
      std::vector<std::string> packets;
      auto sink = [&](std::string_view p) { packets.emplace_back(p); };
      a.Feed(std::string_view(stream).substr(0, cut1), sink);
      a.Feed(std::string_view(stream).substr(cut1, cut2 - cut1), sink);
      a.Feed(std::string_view(stream).substr(cut2), sink);
      ASSERT_EQ(packets.size(), 2u);
      EXPECT_EQ(packets[0], stream.substr(0, 24));
      EXPECT_EQ(packets[1], stream.substr(24));
      EXPECT_EQ(a.Pending(), 0u);
    }
  }
}

// One random input in one of several malformed (or valid) flavours.
std::string RandomInput(std::mt19937& rng) {
  std::uniform_int_distribution<int> flavour(0, 9), byte(0, 255), digit('0', '9'), len(0, 40);
  std::uniform_int_distribution<int> value(-99999, 99999);
  std::string s;
  switch (flavour(rng)) {
    case 0: {  // valid four-digit values, any of them possibly out of limits
      PwmVector v;
      for (int& x : v) x = std::uniform_int_distribution<int>(1000, 9999)(rng);
      return EncodePacket(v);
    }
    case 1: {  // values of any width and sign: negative, huge, short
      for (int i = 0; i < 5; ++i) s += (i ? " " : "") + std::to_string(value(rng));
      return s;
    }
    case 2: {  // 24 random bytes
      for (int i = 0; i < kPacketBytes; ++i) s.push_back(static_cast<char>(byte(rng)));
      return s;
    }
    case 3: {  // random length of random bytes
      const int n = len(rng);
      for (int i = 0; i < n; ++i) s.push_back(static_cast<char>(byte(rng)));
      return s;
    }
    case 4: {  // right shape, one byte replaced
      s = "1545 1530 1545 1580 1530";
      s[std::uniform_int_distribution<int>(0, 23)(rng)] = static_cast<char>(byte(rng));
      return s;
    }
    case 5: {  // digits without separators
      for (int i = 0; i < kPacketBytes; ++i) s.push_back(static_cast<char>(digit(rng)));
      return s;
    }
    case 6:  // short packet
      return std::string("1545 1530 1545").substr(0, std::uniform_int_distribution<int>(0, 14)(rng));
    case 7:  // long packet (with a newline, as a careless client might send)
      return "1545 1530 1545 1580 1530\n";
    case 8: {  // tabs / double spaces instead of single spaces
      return "1545\t1530 1545  580 1530";
    }
    default: {  // "+"/"-" signs inside fields
      return "-545 +530 1545 1580 1530";
    }
  }
}

TEST(LimitsGuardFuzz, MillionMalformedInputsNeverEscapeTheLimits) {
  const models::RobotConfig robot = models::DefaultRobotConfig();
  int64_t log_lines = 0;
  LimitsGuard guard(robot, [&](const std::string&) { ++log_lines; });
  std::mt19937 rng(51);
  PacketAssembler stream;  // one long stream, split across "reads" at random places
  int64_t num_valid = 0, num_rejected = 0, num_direct = 0;
  std::string carry;
  auto check = [&](std::string_view packet) {
    const DecodeResult d = DecodePacket(packet);
    if (!d.pwm_us) {
      ASSERT_FALSE(d.error.empty());
      ++num_rejected;
      return;
    }
    ++num_valid;
    const ClampResult c = guard.Clamp(*d.pwm_us);
    ASSERT_TRUE(guard.WithinLimits(c.pwm_us)) << packet;
    for (int i = 0; i < models::kNumServos; ++i) {
      ASSERT_GE(c.pwm_us[i], robot.servos[i].min_us);
      ASSERT_LE(c.pwm_us[i], robot.servos[i].max_us);
    }
    ASSERT_EQ(EncodePacket(c.pwm_us).size(), size_t(kPacketBytes));
  };
  std::uniform_int_distribution<int> chunk(1, 30);
  for (int i = 0; i < 1000000; ++i) {
    const std::string input = RandomInput(rng);
    // Each input alone, as one packet...
    check(input);
    // ...and as part of a stream cut at random places.
    carry += input;
    while (!carry.empty()) {
      const size_t n = std::min(carry.size(), size_t(chunk(rng)));
      stream.Feed(std::string_view(carry).substr(0, n), check);
      carry.erase(0, n);
    }
    if (i % 10 == 0) {  // and the guard alone on arbitrary integers
      PwmVector v;
      for (int& x : v) {
        const int pick = std::uniform_int_distribution<int>(0, 3)(rng);
        x = pick == 0 ? INT_MIN : pick == 1 ? INT_MAX : std::uniform_int_distribution<int>(-100000, 100000)(rng);
      }
      ASSERT_TRUE(guard.WithinLimits(guard.Clamp(v).pwm_us));
      ++num_direct;
    }
    if (HasFatalFailure()) return;
  }
  // Both paths were exercised, and the guard logged every clamp.
  EXPECT_GT(num_valid, 100000);
  EXPECT_GT(num_rejected, 500000);
  EXPECT_EQ(num_direct, 100000);
  EXPECT_EQ(log_lines, guard.NumClamped());
  EXPECT_GT(guard.NumClamped(), 100000);
}

}  // namespace
}  // namespace owlcal::robot
