#pragma once
// Test helpers: a fast fake robot (virtual clock, fixed synthetic frames, records every
// command) and a decorator that records what another robot is sent.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "robot/limits_guard.h"
#include "robot/robot_interface.h"

namespace owlcal::protocols::testing {

class FakeRobot : public robot::RobotInterface {
 public:
  explicit FakeRobot(models::RobotConfig config = models::DefaultRobotConfig()) : config_(config), guard_(config) {
    cv::RNG rng(7);
    for (int v = 0; v < 3; ++v) {
      cv::Mat small(12, 32, CV_8UC3), sbs;
      rng.fill(small, cv::RNG::UNIFORM, 0, 255);
      cv::resize(small, sbs, cv::Size(1280, 480), 0, 0, cv::INTER_CUBIC);
      cv::putText(sbs, "frame variant " + std::to_string(v), {100, 240}, cv::FONT_HERSHEY_SIMPLEX, 2, {0, 0, 0}, 3);
      std::vector<uint8_t> jpeg;
      cv::imencode(".jpg", sbs, jpeg, {cv::IMWRITE_JPEG_QUALITY, 80});
      jpegs_.push_back(jpeg);
      lefts_.push_back(sbs.colRange(0, 640).clone());
      rights_.push_back(sbs.colRange(640, 1280).clone());
    }
  }
  const models::RobotConfig& Config() const override { return config_; }
  robot::ServoReply SendServos(const robot::PwmVector& pwm_us) override {
    robot::ServoReply r;
    const robot::ClampResult c = guard_.Clamp(pwm_us);
    r.ok = true;
    r.text = "ok";
    r.sent = c.pwm_us;
    r.clamped = c.any_clamped;
    requested.push_back(pwm_us);
    sent.push_back(c.pwm_us);
    now_ += 1'000'000;
    return r;
  }
  std::optional<robot::StereoFrame> GrabFrame(int64_t after, int64_t) override {
    // 30 fps, frame k stamped at k * 33.3 ms; the newest received after `after`.
    int64_t k = now_ / kPeriod;
    if (k * kPeriod <= after) k = after / kPeriod + 1;
    now_ = std::max(now_, k * kPeriod);
    robot::StereoFrame f;
    f.seq = k;
    f.stamp_ns = k * kPeriod;
    const int v = int(k % 3);
    f.jpeg = jpegs_[v];
    f.left = lefts_[v];
    f.right = rights_[v];
    ++frames_grabbed;
    return f;
  }
  int64_t NowNs() override { return now_; }
  void SleepNs(int64_t ns) override { now_ += ns; }
  std::string Describe() const override { return "fake robot"; }

  std::vector<robot::PwmVector> requested, sent;
  int64_t frames_grabbed = 0;

 private:
  static constexpr int64_t kPeriod = 33'333'333;
  models::RobotConfig config_;
  robot::LimitsGuard guard_;
  int64_t now_ = 0;
  std::vector<std::vector<uint8_t>> jpegs_;
  std::vector<cv::Mat> lefts_, rights_;
};

// Forwards everything to `inner` and records every command it is asked to send.
class RecordingRobot : public robot::RobotInterface {
 public:
  explicit RecordingRobot(robot::RobotInterface* inner) : inner_(inner) {}
  const models::RobotConfig& Config() const override { return inner_->Config(); }
  robot::ServoReply SendServos(const robot::PwmVector& p) override {
    requested.push_back(p);
    return inner_->SendServos(p);
  }
  std::optional<robot::StereoFrame> GrabFrame(int64_t a, int64_t t) override { return inner_->GrabFrame(a, t); }
  int64_t NowNs() override { return inner_->NowNs(); }
  void SleepNs(int64_t ns) override { inner_->SleepNs(ns); }
  robot::SceneControl* Scene() override { return inner_->Scene(); }
  std::string Describe() const override { return "recording " + inner_->Describe(); }
  std::vector<robot::PwmVector> requested;

 private:
  robot::RobotInterface* inner_;
};

}  // namespace owlcal::protocols::testing
