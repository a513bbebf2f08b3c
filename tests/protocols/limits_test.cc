// Limits validation on the virtual Owl finds each servo's true usable range within 10 us.
// The truth of a usable end is the first, going outward from the centre, of: the physical
// end-stop (robot-truth file), the socket rim (computed from the truth geometry: the pulse
// width at which the rim darkens one of the 16 border segments of protocols/image_motion.h by
// the protocol's rim_fraction), and the configured limit of the robot file.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "evaluation/limits_eval.h"
#include "owlcal_version.h"
#include "protocols/dataset.h"
#include "protocols/dataset_tables.h"
#include "protocols/image_motion.h"
#include "protocols/protocol.h"
#include "protocols/runner.h"
#include "robot/robot_interface.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal::protocols {
namespace {
namespace fs = std::filesystem;

// The rim "intrudes" when it dims more than rim_fraction (2 %) of the border band's pixels to
// under a quarter of their brightness (the runner sees such pixels fall below grey 20).
constexpr double kDim = 0.25;

// The unit rays of the pixels of an 8 px border band (every second pixel) of the eye's image:
// the same at every pulse, so computed once per eye.
std::vector<Eigen::Vector3d> BorderRays(const models::CameraIntrinsics& k) {
  const int b = 8;
  std::vector<Eigen::Vector3d> rays;
  for (int y = 0; y < k.height; y += 2)
    for (int x = 0; x < k.width; x += 2) {
      if (!(x < b || y < b || x >= k.width - b || y >= k.height - b)) continue;
      const double px[2] = {double(x), double(y)};
      double ray[3];
      if (k.Unproject(px, ray)) rays.push_back(Eigen::Vector3d(ray[0], ray[1], ray[2]).normalized());
    }
  return rays;
}

// Fraction of the border band (`rays`, BorderRays of the servo's eye) that the rim dims to under
// `dim` of its brightness, for servo `servo` at pulse u.
double TruthRimDarkening(const sim::VirtualOwl& owl,
                         const std::vector<Eigen::Vector3d>& rays,
                         int servo,
                         double u,
                         int approach,
                         double dim) {
  const models::HeadModel head = owl.TruthHeadModel();
  const sim::RobotTruth& truth = owl.Truth();
  const int eye = servo == models::kLx || servo == models::kLy ? models::kLeftEye : models::kRightEye;
  std::array<double, models::kNumServos> pwm;
  std::array<int, models::kNumServos> appr{};
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = truth.robot.servos[i].centre_us;
  pwm[servo] = u;
  appr[servo] = approach;
  models::JointAngles a = head.Angles(pwm, appr);
  a.neck_rad = 0;  // cam_from_base with the neck at zero is cam_from_head
  const Eigen::Vector3d axis = (owl.CamFromBase(models::Eye(eye), a).rotation * Eigen::Vector3d::UnitZ()).normalized();
  const double cos_start = std::cos((truth.socket.rim_half_angle_deg - truth.socket.rim_softness_deg) * M_PI / 180);
  const double cos_end = std::cos(truth.socket.rim_half_angle_deg * M_PI / 180);
  double dark = 0;
  for (const Eigen::Vector3d& ray : rays) {
    const double c = ray.dot(axis);
    double factor = 1;
    if (c < cos_start) {
      double f = std::min(1.0, (cos_start - c) / (cos_start - cos_end));
      f = f * f * (3 - 2 * f);
      factor = 1 - (1 - truth.socket.rim_floor) * f;
    }
    dark += factor < dim;
  }
  return rays.empty() ? 0 : dark / rays.size();
}

// The true usable end of a servo (d = +1 high end, -1 low end) and its cause.
int TruthEnd(const sim::VirtualOwl& owl, int servo, int d, double rim_fraction, std::string* cause) {
  const sim::RobotTruth& t = owl.Truth();
  const models::ServoConfig& c = t.robot.servos[servo];
  const double stop = d > 0 ? t.servos[servo].endstop_hi_us : t.servos[servo].endstop_lo_us;
  const int eye = servo == models::kLx || servo == models::kLy ? models::kLeftEye : models::kRightEye;
  const std::vector<Eigen::Vector3d> rays =
      servo == models::kNeck ? std::vector<Eigen::Vector3d>{} : BorderRays(t.intrinsics[eye]);
  for (int u = c.centre_us;; u += d) {
    if (servo != models::kNeck && TruthRimDarkening(owl, rays, servo, u, d, kDim) > rim_fraction) {
      *cause = "rim";
      return u - d;
    }
    if ((d > 0 && u >= stop) || (d < 0 && u <= stop)) {
      *cause = "end-stop";
      return int(std::lround(stop));
    }
    if (u == (d > 0 ? c.max_us : c.min_us)) {
      *cause = "configured";
      return u;
    }
  }
}

// max_error_us bounds end-stops and configured ends; a rim end (where the socket rim darkens the
// border, a soft threshold) is allowed rim_error_us. With check_recommended, the recommended
// limits (evaluation/limits_eval.h, 10 us margin + 5 us for the search's error) must keep >= 10 us from every true
// end-stop that lies inside the configured range.
// With max_backlash_error_us >= 0, every end's backlash_us must be within it of the truth's band
// (2 hysteresis_us).
void CheckLimits(const sim::VirtualOwlOptions& vo,
                 const std::string& name,
                 const std::vector<int>& servos = {},
                 int max_error_us = 10,
                 int rim_error_us = 10,
                 bool check_recommended = false,
                 double max_backlash_error_us = -1) {
  sim::VirtualOwl owl(vo);
  Protocol p = LoadProtocolFile(ResolveProtocolPath("limits"));
  ASSERT_TRUE(p.steps[1].As<LimitsStep>().search_ends);
  p.steps.resize(2);  // the ends only (the resolution probe after them: servo_resolution_pipeline_test)
  if (!servos.empty()) p.steps[1].As<LimitsStep>().servos = servos;
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_limits_" + name + "_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  const RunSummary s = RunProtocols({p}, owl, o);
  ASSERT_EQ(s.status, "complete") << s.message;
  EXPECT_EQ(s.num_clamped, 0);
  int rows = 0;
  std::vector<evaluation::LimitMeasurement> measurements;
  for (const LimitRow& row : ReadLimitsCsv(o.out_dir)) {
    const std::string what = row.servo + " " + row.end;
    const int servo = ServoIndexFromName(row.servo);
    const int d = row.end == "max" ? 1 : -1;
    ASSERT_TRUE(row.measured_us) << what;
    const int measured = *row.measured_us;
    std::string cause;
    const int truth = TruthEnd(owl, servo, d, p.steps[1].As<LimitsStep>().rim_fraction, &cause);
    std::cout << name << " " << what << ": measured " << measured << " (" << row.cause << "), truth " << truth << " ("
              << cause << "), error " << measured - truth << " us\n";
    EXPECT_LE(std::abs(measured - truth), cause == "rim" ? rim_error_us : max_error_us) << what;
    EXPECT_EQ(row.cause, cause) << what;
    EXPECT_EQ(row.status, calib::TrialStatus::kOk) << what;
    if (row.beyond_rim_reason == "end-stop") {
      // Past the rim, the stop the rim hides: at approach 0 too.
      const double stop = d > 0 ? owl.Truth().servos[servo].endstop_hi_us : owl.Truth().servos[servo].endstop_lo_us;
      ASSERT_TRUE(row.beyond_rim_us) << what;
      std::cout << name << " " << what << ": beyond the rim " << *row.beyond_rim_us << ", true stop " << stop << "\n";
      EXPECT_LE(std::abs(*row.beyond_rim_us - stop), max_error_us) << what;
    }
    if (max_backlash_error_us >= 0) {
      const double band = 2 * owl.Truth().servos[servo].hysteresis_us;
      ASSERT_TRUE(row.backlash_us) << what << ": no backlash measured";
      std::cout << name << " " << what << ": backlash " << *row.backlash_us << " us, truth " << band << " us\n";
      EXPECT_NEAR(*row.backlash_us, band, max_backlash_error_us) << what;
    }
    measurements.push_back({servo, d > 0, double(measured), evaluation::LimitCauseFromName(row.cause)});
    ++rows;
  }
  EXPECT_EQ(rows, 2 * int(p.steps[1].As<LimitsStep>().servos.size()));
  if (check_recommended) {
    const evaluation::LimitsEvaluation ev = evaluation::EvaluateLimits(owl.Config(), measurements, nullptr, 10);
    const sim::RobotTruth& t = owl.Truth();
    for (const evaluation::ServoLimits& sl : ev.servos) {
      if (!sl.measured_min_us || !sl.measured_max_us) continue;
      const models::ServoConfig& c = t.robot.servos[sl.servo];
      const double lo = t.servos[sl.servo].endstop_lo_us, hi = t.servos[sl.servo].endstop_hi_us;
      std::cout << name << " " << sl.name << ": recommended " << sl.recommended_min_us << "-" << sl.recommended_max_us
                << " us, true stops " << lo << " / " << hi << " us\n";
      if (lo >= c.min_us) {
        EXPECT_GE(sl.recommended_min_us - lo, 10.0) << sl.name << " low stop " << lo;
      }
      if (hi <= c.max_us) {
        EXPECT_GE(hi - sl.recommended_max_us, 10.0) << sl.name << " high stop " << hi;
      }
      EXPECT_LT(sl.recommended_min_us, sl.recommended_max_us) << sl.name;
    }
  }
  fs::remove_all(o.out_dir);
}

TEST(Limits, FindsTheTrueUsableRangeWithin10usOnTheDefaultRobot) { CheckLimits(sim::VirtualOwlOptions{}, "default"); }

TEST(Limits, FindsEndStopsInsideTheConfiguredRange) {
  sim::VirtualOwlOptions vo;
  sim::RobotTruth t = sim::DefaultRobotTruth();
  t.servos[models::kNeck].endstop_lo_us = 1340;
  t.servos[models::kNeck].endstop_hi_us = 1790;
  t.servos[models::kRx].endstop_hi_us = 1700;
  t.servos[models::kLy].endstop_lo_us = 1480;
  vo.truth = t;
  vo.seed = 3;
  CheckLimits(vo, "endstops");
}

// A robot built like real ones: 5 us PWM steps, dead bands of 2-5 us, and stops inside the
// configured range, one inside the last 20 us coarse step of its limit. Every end within 5 us.
TEST(Limits, FiveMicrosecondStepsAndDeadBandsStopsInsideTheLastCoarseStep) {
  sim::VirtualOwlOptions vo;
  sim::RobotTruth t = sim::DefaultRobotTruth();
  for (auto& s : t.servos) {
    s.quantum_us = 5;
    s.dead_band_us = 3;
  }
  t.servos[models::kNeck].dead_band_us = 5;
  t.servos[models::kNeck].endstop_hi_us = t.robot.servos[models::kNeck].max_us - 13;  // inside the last coarse step
  t.servos[models::kNeck].endstop_lo_us = t.robot.servos[models::kNeck].min_us + 57;
  t.servos[models::kRx].dead_band_us = 2;
  t.servos[models::kRx].endstop_hi_us = t.robot.servos[models::kRx].centre_us + 163;
  vo.truth = t;
  vo.seed = 5;
  CheckLimits(vo, "pwm5", {models::kRx, models::kNeck}, 5, 10, true);
}

sim::VirtualOwlOptions RobotFile(const std::string& file, int seed) {
  sim::VirtualOwlOptions vo;
  vo.truth = sim::LoadRobotTruth(std::string(OWLCAL_SOURCE_DIR) + "/" + file);
  vo.seed = seed;
  return vo;
}

// The shipped test robots (tests/data/robots/): 5 us PWM steps with dead bands of 2-5 us, and
// 1 us pulses with dead bands of 2-5 us. On both, Ry's top stop (1985 us, limit 2000) and Ly's
// bottom stop (1190 us, limit 1180) lie inside the last 20 us coarse step. Every end-stop within
// 5 us of the truth (rims are named as such), and the recommended limits keep 10 us from every
// stop inside the configured range.
TEST(Limits, Step5RobotEveryStopWithin5usAndRecommendedLimitsKeep10us) {
  CheckLimits(RobotFile("tests/data/robots/owl_step5_truth.yaml", 7), "step5", {}, 5, 10, true);
}

TEST(Limits, DeadBandRobotEveryStopWithin5usAndRecommendedLimitsKeep10us) {
  CheckLimits(RobotFile("tests/data/robots/owl_deadband_truth.yaml", 7), "deadband", {}, 5, 10, true);
}

// Cheap, slow servos (tests/data/robots/owl_slow_servos_truth.yaml): slew 160-220 deg/s, lag
// 80-120 ms, the neck's 11 us backlash band plus a 6 us dead band, stops inside the configured
// range, a 15 fps stream with 200 ms latency. The probe watches the image until it stops moving and
// measures the backlash band: the protocol completes, every end lies within 5 us of the truth
// (the stops at approach 0, as the truth gives them) and every band within 2 us.
TEST(Limits, SlowServosEveryEndWithin5usAndTheBacklashMeasured) {
  CheckLimits(RobotFile("tests/data/robots/owl_slow_servos_truth.yaml", 13), "slow", {}, 5, 10, true, 2.0);
}

// The neck: a stop at 1935 us under a configured 1950 us limit (inside the last coarse
// step), on 1 us pulses with a 3 us dead band; and a 5 us-step eye configured inside its socket
// rim (min 1330 us, rim at 1302 us) whose stop is 7 us inside that limit.
TEST(Limits, StopsInsideTheLastCoarseStepOnOneMicrosecondPulses) {
  sim::VirtualOwlOptions vo;
  sim::RobotTruth t = sim::DefaultRobotTruth();
  for (auto& s : t.servos) s.dead_band_us = 3;
  t.servos[models::kNeck].endstop_hi_us = 1935;
  t.servos[models::kRx].quantum_us = 5;
  t.robot.servos[models::kRx].min_us = 1330;
  t.servos[models::kRx].endstop_lo_us = 1337;
  vo.truth = t;
  vo.seed = 11;
  CheckLimits(vo, "lastcoarse", {models::kRx, models::kNeck}, 5, 10, true);
}

// Forwards to a robot, but one eye's image is black (a lens cap, a dead camera).
class BlackEyeRobot : public robot::RobotInterface {
 public:
  BlackEyeRobot(robot::RobotInterface* inner, int eye) : inner_(inner), eye_(eye) {}
  const models::RobotConfig& Config() const override { return inner_->Config(); }
  robot::ServoReply SendServos(const robot::PwmVector& pwm_us) override { return inner_->SendServos(pwm_us); }
  std::optional<robot::StereoFrame> GrabFrame(int64_t after, int64_t timeout) override {
    auto f = inner_->GrabFrame(after, timeout);
    if (f) {
      cv::Mat& img = eye_ == models::kLeftEye ? f->left : f->right;
      img = cv::Mat(img.size(), img.type(), cv::Scalar::all(3));
    }
    return f;
  }
  int64_t NowNs() override { return inner_->NowNs(); }
  void SleepNs(int64_t ns) override { inner_->SleepNs(ns); }
  robot::SceneControl* Scene() override { return inner_->Scene(); }
  std::string Describe() const override { return "black left eye on " + inner_->Describe(); }

 private:
  robot::RobotInterface* inner_;
  int eye_;
};

// Regression: a black camera half reported "configured" limits and end-stops at the centre.
// Now the step fails with a message, the black eye's ends are rows with status "failed" and no
// measured value, and the other eye's servo is still measured.
TEST(Limits, BlackCameraFailsWithAMessageAndNeverPassesAsConfigured) {
  sim::VirtualOwl owl(sim::VirtualOwlOptions{});
  BlackEyeRobot robot(&owl, models::kLeftEye);
  Protocol p = LoadProtocolFile(ResolveProtocolPath("limits"));
  p.steps.resize(2);  // the ends only
  p.steps[1].As<LimitsStep>().servos = {models::kLx, models::kRx};
  RunOptions o;
  o.out_dir = (fs::temp_directory_path() / ("owlcal_limits_black_" + std::to_string(::getpid()))).string();
  fs::remove_all(o.out_dir);
  const RunSummary s = RunProtocols({p}, robot, o);
  EXPECT_EQ(s.status, "failed");
  EXPECT_NE(s.message.find("2 of 4 ends could not be measured"), std::string::npos) << s.message;
  EXPECT_NE(s.message.find("black or constant"), std::string::npos) << s.message;
  int rows = 0, failed = 0;
  for (const LimitRow& row : ReadLimitsCsv(o.out_dir)) {
    const std::string at = "limits.csv:" + std::to_string(row.line);
    ++rows;
    if (row.servo == "Lx") {
      ++failed;
      EXPECT_EQ(row.status, calib::TrialStatus::kFailed) << at;
      EXPECT_FALSE(row.measured_us) << at;  // no measured value
      EXPECT_NE(row.cause, "configured") << at;
      EXPECT_NE(row.cause, "end-stop") << at;
      EXPECT_FALSE(row.message.empty()) << at;
    } else {
      EXPECT_EQ(row.status, calib::TrialStatus::kOk) << at;
      EXPECT_TRUE(row.measured_us) << at;
    }
  }
  EXPECT_EQ(rows, 4);
  EXPECT_EQ(failed, 2);
  fs::remove_all(o.out_dir);
}

}  // namespace
}  // namespace owlcal::protocols
