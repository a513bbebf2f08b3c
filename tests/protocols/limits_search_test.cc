// The end-stop search on a synthetic eye: a textured wall that shifts by the pulse the servo
// APPLIED (PWM step and dead band, models/servo_resolution.h), which stops at an end-stop.
// Stops anywhere (also inside the last coarse step, just inside the limit), PWM steps of 1,
// 2, 5 and 10 us with dead bands up to 5 us: every stop within 5 us of the truth. A black,
// covered or frozen camera fails with a message and never passes as "configured".
#include "protocols/limits_search.h"

#include <algorithm>
#include <cmath>
#include <iostream>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "models/servo_resolution.h"

namespace owlcal::protocols {
namespace {

constexpr double kPxPerUs = 1.15;  // 0.113 deg/us at f = 585 px

class SyntheticEye {
 public:
  SyntheticEye(models::ServoResolution res, int centre, double stop_lo, double stop_hi)
      : res_(res), state_{centre, 1}, stop_lo_(stop_lo), stop_hi_(stop_hi), centre_(centre) {
    cv::RNG rng(11);
    cv::Mat small(40, 60, CV_8UC1);
    rng.fill(small, cv::RNG::UNIFORM, 40, 220);
    cv::resize(small, wall_, cv::Size(1600, 300), 0, 0, cv::INTER_CUBIC);
  }
  void Move(int u) { state_ = res_.Next(state_, u); }
  double PositionUs() const { return std::clamp(double(state_.applied_us), stop_lo_, stop_hi_); }
  cv::Mat Image() const {
    if (black) return cv::Mat(240, 320, CV_8UC3, cv::Scalar(2, 2, 2));
    const double x = 640 + (frozen ? 0.0 : (PositionUs() - centre_) * kPxPerUs);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, -x, 0, 1, -30);
    cv::Mat out, bgr;
    cv::warpAffine(wall_, out, m, cv::Size(320, 240), cv::INTER_LINEAR);
    cv::cvtColor(out, bgr, cv::COLOR_GRAY2BGR);
    return bgr;
  }
  LimitSearchIo Io() {
    return {[this](int u) { Move(u); }, [this] { return Image(); }, {}};
  }
  bool black = false, frozen = false;

 private:
  models::ServoResolution res_;
  models::ServoState state_;
  double stop_lo_, stop_hi_;
  int centre_;
  cv::Mat wall_;
};

LimitSearchOptions Options() {
  LimitSearchOptions o;
  o.coarse_us = 20;
  o.fine_us = 4;
  o.check_rim = false;
  return o;
}

struct Case {
  int step, dead_band;
  double stop;  // high-end stop
  int limit;    // configured high limit
};

TEST(LimitSearch, FindsStopsWithin5usWhateverThePwmStep) {
  const int centre = 1500;
  const Case cases[] = {
      {1, 1, 1637, 1700},
      {1, 3, 1689, 1700},  // inside the last coarse step
      {2, 2, 1651, 1700},
      {5, 2, 1637, 1700},
      {5, 5, 1663, 1700},
      {5, 3, 1696, 1700},
      {5, 4, 1692, 1700},
      {5, 5, 1612, 1700},  // just inside the limit; early
      {10, 1, 1648, 1700},
      {1, 1, 1800, 1700},
      {5, 5, 1750, 1700},  // beyond the limit: configured
  };
  for (const Case& c : cases) {
    SyntheticEye eye(models::ServoResolution::Rounding(c.step, c.dead_band), centre, 1000, c.stop);
    const LimitSearchResult r = SearchLimit(centre, c.limit, 0, kPxPerUs, Options(), eye.Io());
    const std::string what = "step " + std::to_string(c.step) + " us, dead band " + std::to_string(c.dead_band) +
                             " us, stop " + std::to_string(int(c.stop)) + ": measured " +
                             std::to_string(r.measured_us) + " (" + r.cause + ") " + r.message;
    std::cout << what << "\n";
    ASSERT_EQ(r.status, calib::TrialStatus::kOk) << what;
    if (c.stop >= c.limit) {
      EXPECT_EQ(r.cause, "configured") << what;
      EXPECT_EQ(r.measured_us, c.limit) << what;
    } else {
      EXPECT_LE(std::abs(r.measured_us - c.stop), 5.0) << what;
      if (c.limit - c.stop > 5) {
        EXPECT_EQ(r.cause, "end-stop") << what;
      }
    }
    EXPECT_NEAR(r.px_per_us, kPxPerUs, 0.05 * kPxPerUs) << what;
  }
}

TEST(LimitSearch, LowEndToo) {
  const int centre = 1500;
  for (int step : {1, 5}) {
    SyntheticEye eye(models::ServoResolution::Rounding(step, 3), centre, 1357, 2000);
    const LimitSearchResult r = SearchLimit(centre, 1300, 0, kPxPerUs, Options(), eye.Io());
    ASSERT_EQ(r.status, calib::TrialStatus::kOk) << r.message;
    EXPECT_EQ(r.cause, "end-stop") << r.message;
    EXPECT_LE(std::abs(r.measured_us - 1357), 5) << r.measured_us << " " << r.message;
  }
}

// A slow servo with backlash on the same wall: the joint (pulse-equivalent) is the applied pulse
// minus approach * hysteresis, clamped to the stops (given at approach 0, as sim/robot_truth.h);
// after a move the first image shows it a `lag` fraction short of where it goes, and every later
// frame halves what is left (a first-order lag).
class SlowBacklashEye {
 public:
  SlowBacklashEye(double hysteresis_us, double lag, int dead_band, double stop_hi)
      : res_(models::ServoResolution::Rounding(1, dead_band)), h_(hysteresis_us), lag_(lag), stop_hi_(stop_hi) {
    cv::RNG rng(11);
    cv::Mat small(40, 60, CV_8UC1);
    rng.fill(small, cv::RNG::UNIFORM, 40, 220);
    cv::resize(small, wall_, cv::Size(1600, 300), 0, 0, cv::INTER_CUBIC);
  }
  double Target() const { return std::min(stop_hi_, state_.applied_us - h_ * state_.approach); }
  LimitSearchIo Io(bool with_settle) {
    LimitSearchIo io;
    io.move = [this](int u) {
      state_ = res_.Next(state_, u);
      shown_ = Target() + lag_ * (shown_ - Target());
    };
    io.image = [this] { return Image(); };
    if (with_settle)
      io.settle = [this](const cv::Mat&, bool reference) {
        SettledImage s;
        double moved = 1e9;
        while (moved * kPxPerUs >= (reference ? 0.3 : 0.6)) {
          const double next = Target() + 0.5 * (shown_ - Target());
          moved = std::abs(next - shown_);
          shown_ = next;
          ++s.frames;
          s.still_at_first_look = s.still_at_first_look && !(s.frames == 1 && moved * kPxPerUs >= 0.6);
        }
        s.image = Image();
        return s;
      };
    return io;
  }

 private:
  cv::Mat Image() const {
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, -(640 + (shown_ - 1500) * kPxPerUs), 0, 1, -30);
    cv::Mat out;
    cv::warpAffine(wall_, out, m, cv::Size(320, 240), cv::INTER_LINEAR);
    return out;
  }
  models::ServoResolution res_;
  models::ServoState state_{1500, 1};
  double h_, lag_, stop_hi_, shown_ = 1500;
  cv::Mat wall_;
};

// Watched until still, the slow servo's stop comes back within 2 us of the truth (at approach 0,
// though the probes meet it half a band later) and its 11 us backlash band within 1 us; the search
// names the servo slow. With the image taken after the wait alone, the lag and the backlash put the
// stop several us outward.
TEST(LimitSearch, SlowBacklashedServoIsWatchedUntilStillAndItsBacklashMeasured) {
  const double stop = 1663;
  SlowBacklashEye eye(5.5, 0.6, 6, stop);
  const LimitSearchResult r = SearchLimit(1500, 1700, 0, kPxPerUs, Options(), eye.Io(true));
  ASSERT_EQ(r.status, calib::TrialStatus::kOk) << r.message;
  std::cout << "watched: measured " << r.measured_us << " (" << r.cause << "), met " << r.met_us << ", backlash "
            << (r.backlash_us ? *r.backlash_us : -1) << ": " << r.message << "\n";
  EXPECT_EQ(r.cause, "end-stop");
  EXPECT_TRUE(r.slow);
  EXPECT_GE(r.watched, r.probes);
  EXPECT_LE(std::abs(r.measured_us - stop), 2) << r.message;
  ASSERT_TRUE(r.backlash_us);
  EXPECT_NEAR(*r.backlash_us, 11, 1.0) << r.message;
  EXPECT_NEAR(r.met_us - r.measured_us, 5.5, 1.0);

  SlowBacklashEye unwatched(5.5, 0.6, 6, stop);
  const LimitSearchResult u = SearchLimit(1500, 1700, 0, kPxPerUs, Options(), unwatched.Io(false));
  std::cout << "unwatched: measured " << u.measured_us << " (" << u.cause << "): " << u.message << "\n";
  EXPECT_GT(std::abs(u.measured_us - stop), 2) << u.message;
}

TEST(LimitSearch, BlackOrCoveredCameraFailsWithAMessage) {
  SyntheticEye eye(models::ServoResolution::Rounding(1, 1), 1500, 1000, 2000);
  eye.black = true;
  const LimitSearchResult r = SearchLimit(1500, 1700, 0, kPxPerUs, Options(), eye.Io());
  EXPECT_EQ(r.status, calib::TrialStatus::kFailed);
  EXPECT_TRUE(r.cause.empty());
  EXPECT_NE(r.message.find("black or constant"), std::string::npos) << r.message;
}

TEST(LimitSearch, FrozenCameraFailsInsteadOfAStopAtTheCentre) {
  SyntheticEye eye(models::ServoResolution::Rounding(1, 1), 1500, 1000, 2000);
  eye.frozen = true;
  const LimitSearchResult r = SearchLimit(1500, 1700, 0, kPxPerUs, Options(), eye.Io());
  EXPECT_EQ(r.status, calib::TrialStatus::kFailed);
  EXPECT_TRUE(r.cause.empty());
  EXPECT_NE(r.message.find("no image motion"), std::string::npos) << r.message;
}

TEST(LimitSearch, RejectsBadOptions) {
  SyntheticEye eye(models::ServoResolution::Rounding(1, 1), 1500, 1000, 2000);
  LimitSearchOptions o = Options();
  o.fine_us = 30;
  EXPECT_THROW(SearchLimit(1500, 1700, 0, kPxPerUs, o, eye.Io()), std::invalid_argument);
  EXPECT_THROW(SearchLimit(1500, 1700, 0, 0.0, Options(), eye.Io()), std::invalid_argument);
}

}  // namespace
}  // namespace owlcal::protocols
