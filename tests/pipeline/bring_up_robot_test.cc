// Calibrate on a robot its file does not describe (tests/data/robots/owl_reassembled_truth.yaml:
// the Ly horn reversed, centres 60-75 us off, every end-stop 35-90 us inside the file's limits,
// 5 us PWM steps): the limits protocol's bring-up learns the reversed horn and the stops, every
// command after it stays inside the measured stops minus the margin, the fixations still converge
// and range, and the learned configuration is what the later datasets record.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "owlcal_version.h"
#include "pipeline/calibrate.h"
#include "robot/reconfigured_robot.h"
#include "sim/robot_truth.h"
#include "sim/virtual_owl.h"

namespace owlcal {
namespace {

namespace fs = std::filesystem;

// Every command sent once `armed` is set, and the widest range each servo was commanded over.
class CommandSpy : public robot::ReconfiguredRobot {
 public:
  explicit CommandSpy(robot::RobotInterface& robot) : ReconfiguredRobot(robot, robot.Config()) {
    lo_.fill(1 << 20);
    hi_.fill(-(1 << 20));
  }
  robot::ServoReply SendServos(const robot::PwmVector& pwm_us) override {
    if (armed)
      for (int s = 0; s < models::kNumServos; ++s) {
        lo_[s] = std::min(lo_[s], pwm_us[s]);
        hi_[s] = std::max(hi_[s], pwm_us[s]);
      }
    return ReconfiguredRobot::SendServos(pwm_us);
  }
  bool armed = false;
  int lo(int s) const { return lo_[s]; }
  int hi(int s) const { return hi_[s]; }

 private:
  std::array<int, models::kNumServos> lo_{}, hi_{};
};

TEST(BringUpRobot, AReassembledRobotIsMeasuredThenDrivenOnWhatWasLearned) {
  const std::string protocols = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/protocols/";
  const std::string truth_file = std::string(OWLCAL_SOURCE_DIR) + "/tests/data/robots/owl_reassembled_truth.yaml";
  const sim::RobotTruth truth = sim::LoadRobotTruth(truth_file);
  sim::VirtualOwlOptions vo;
  vo.truth = truth;
  vo.seed = 5;
  sim::VirtualOwl owl(vo);
  CommandSpy spy(owl);
  const fs::path root = fs::temp_directory_path() / ("owlcal_bring_up_robot_" + std::to_string(::getpid()));
  fs::remove_all(root);
  pipeline::CalibrateOptions co;
  co.out = root.string();
  co.protocols = {
      "limits", protocols + "mc_stereo.yaml", protocols + "mc_servo_sweep.yaml", protocols + "vergence_short.yaml"};
  co.truth = truth;
  co.robot.sim = {{"seed", 5}, {"truth_file", truth_file}};
  // Armed once the first protocol after the limits protocol starts.
  co.progress = [&](const std::string& line) {
    if (line.rfind("protocol ", 0) == 0 && line.rfind("protocol limits", 0) != 0) spy.armed = true;
  };
  const evaluation::CalibrationRun run = pipeline::Calibrate(spy, co);

  ASSERT_TRUE(run.result.diagnostics.contains("bring_up"));
  const nlohmann::json& b = run.result.diagnostics["bring_up"];
  bool reversed = false;
  for (const auto& f : b.at("findings"))
    reversed |= f.get<std::string>().find("for Ly; the robot turns +1") != std::string::npos;
  EXPECT_TRUE(reversed) << b.dump(1);
  EXPECT_EQ(run.config.servos[models::kLy].direction, +1);
  for (int s = 0; s < models::kNumServos; ++s) {
    const models::ServoConfig& used = run.config.servos[s];
    const sim::ServoTruth& t = truth.servos[s];
    const std::string name = models::kServoNames[s];
    // The learned range is inside the true stops, and not much narrower than it needs to be.
    EXPECT_GT(used.min_us, t.endstop_lo_us) << name;
    EXPECT_LT(used.max_us, t.endstop_hi_us) << name;
    EXPECT_LE(used.min_us, t.endstop_lo_us + 30) << name;
    EXPECT_GE(used.max_us, t.endstop_hi_us - 30) << name;
    // No command after the bring-up left it.
    EXPECT_GE(spy.lo(s), used.min_us) << name;
    EXPECT_LE(spy.hi(s), used.max_us) << name;
  }
  for (const auto& [name, r] : run.settings.at("runs").items())
    EXPECT_EQ(r.at("status"), "complete") << name << ": " << r.at("message");
  ASSERT_TRUE(run.ranging);
  EXPECT_GE(run.ranging->num_ok, 4) << "of " << run.ranging->rows.size();
  EXPECT_LE(run.ranging->rms_rel_error, 0.01);

  // The robot file as measured (robot_corrected.yaml): the truth's directions, and its eye servos'
  // centres within 6 us (the neck's centre is the head-yaw gauge's: the file's, by definition).
  std::vector<std::string> changes;
  const models::RobotConfig corrected = pipeline::CorrectedRobotFile(truth.robot, run.config, run.result, &changes);
  for (int s = 0; s < models::kNumServos; ++s) {
    const std::string name = models::kServoNames[s];
    EXPECT_EQ(corrected.servos[s].direction, truth.servos[s].direction) << name;
    if (s != models::kNeck) {
      EXPECT_NEAR(corrected.servos[s].centre_us, truth.servos[s].centre_us, 6) << name;
    }
  }
  EXPECT_NEAR(corrected.ipd_m, 0.0685, 0.0005);
  // The learned limits are on the 5 us grid (poses derived from them are pulses a 5 us servo
  // applies as commanded).
  for (int s = 0; s < models::kNumServos; ++s) {
    EXPECT_EQ(run.config.servos[s].min_us % 5, 0) << models::kServoNames[s];
    EXPECT_EQ(run.config.servos[s].max_us % 5, 0) << models::kServoNames[s];
  }

  // fit-datasets reads the same bring-up from the recorded datasets and applies it the same way.
  pipeline::FitDatasetsOptions fo;
  const evaluation::CalibrationRun refit = pipeline::FitDatasets(root.string(), fo);
  EXPECT_EQ(refit.result.diagnostics.at("bring_up"), b);
  EXPECT_EQ(refit.config.servos[models::kNeck].max_us, run.config.servos[models::kNeck].max_us);
  fs::remove_all(root);
}

}  // namespace
}  // namespace owlcal
