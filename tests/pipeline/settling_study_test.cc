// The settling study calibrate makes from a step-response dataset: a robot that is the loop
// model agrees with it; a dataset with nothing to fit is a named warning, not a made-up model.
#include "pipeline/settling_study.h"

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "calib/trial_status.h"
#include "fitting/loop_model.h"
#include "protocols/dataset.h"
#include "protocols/protocol.h"

namespace owlcal::pipeline {
namespace settling_study_test {
namespace fs = std::filesystem;

const char* kResponseHeader =
    "step_index,gain,amplitude_deg,trial,k,t_s,offset_px,offset_y_px,pwm_us,found,frame_index";
const char* kTrialsHeader =
    "step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,final_offset_px,"
    "message,status,reason";

std::string S(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.6f", v);
  return b;
}

// A step-response dataset recorded on a robot that is `robot` (the loop model), and its trials.
std::vector<fitting::StepTrace> Record(const fs::path& dir, const fitting::LoopModel& robot, double deg_per_us) {
  auto w = protocols::DatasetWriter::Create(dir.string(), {{"protocols", {{{"name", "step_response"}}}}});
  std::vector<fitting::StepTrace> out;
  uint64_t seed = 500;
  for (double gain : {0.1, 0.2})
    for (double amp : {5.0, 10.0})
      for (int trial = 0; trial < 2; ++trial) {
        const double amp_us = amp / deg_per_us * (trial ? -1 : 1);
        const fitting::LoopTrial t = fitting::SimulateLoopStep(robot, gain, amp_us, 75, seed++);
        for (size_t k = 0; k < t.t_s.size(); ++k)
          w->AppendRow("step_response.csv",
                       kResponseHeader,
                       {"1",
                        S(gain),
                        S(amp),
                        std::to_string(trial),
                        std::to_string(k),
                        S(t.t_s[k]),
                        S(t.offset_px[k]),
                        "0",
                        std::to_string(1500 + t.command_us[k]),
                        "1",
                        "-1"});
        const std::string status =
            calib::TrialStatusName(t.info.settled ? calib::TrialStatus::kOk : calib::TrialStatus::kNotSettled);
        w->AppendRow("step_trials.csv",
                     kTrialsHeader,
                     {"1",
                      S(gain),
                      S(amp),
                      std::to_string(trial),
                      "right",
                      "pan",
                      "Rx",
                      std::to_string(1500 + t.command_us.front()),
                      "1500",
                      t.info.settled ? "converged" : "not-settled",
                      "75",
                      S(t.offset_px.back()),
                      "",
                      status,
                      t.info.settled ? "" : "not converged"});
        fitting::StepTrace s;
        s.gain = gain;
        s.amplitude_deg = amp;
        s.trial = trial;
        s.t_s = t.t_s;
        s.y = t.y;
        s.info = t.info;
        s.status = t.info.settled ? calib::TrialStatus::kOk : calib::TrialStatus::kNotSettled;
        out.push_back(s);
      }
  w->Finish("complete", "");
  return out;
}

fs::path TempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("owlcal_settling_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

TEST(SettlingStudy, ARobotThatIsTheLoopModelAgreesWithTheModelFittedFromItsSteps) {
  fitting::LoopModel robot;
  robot.exposure_delay_s = 0.1;
  robot.lag_s = 0.03;
  robot.slew_us_per_s = 3300;
  robot.nominal_px_per_us = 585.0 * std::tan(0.113 * M_PI / 180);
  robot.px_per_us = robot.nominal_px_per_us;
  robot.tolerance_px = protocols::ClosedLoopSettings{}.tolerance_px;
  const fs::path dir = TempDir("agree");
  const auto steps = Record(dir, robot, 0.113);
  std::vector<std::string> warnings;
  const auto st = StudySettling(
      dir.string(), steps, models::DefaultRobotConfig(), fitting::CalibrationResult{}, 133.0, 4, 30.0, &warnings);
  ASSERT_TRUE(st.has_value()) << (warnings.empty() ? "" : warnings[0]);
  EXPECT_TRUE(warnings.empty());
  // The fitted motion is the robot's.
  EXPECT_NEAR(st->model.exposure_delay_s, 0.1, 0.01);
  EXPECT_NEAR(st->model.px_per_us, robot.px_per_us, 0.05 * robot.px_per_us);
  ASSERT_EQ(st->rows.size(), 4u);
  int agree = 0;
  for (const auto& r : st->rows) {
    EXPECT_EQ(r.num_trials, 2);
    EXPECT_EQ(r.num_ok, 2);
    agree += r.agreement.rfind("agrees", 0) == 0;
  }
  EXPECT_GE(agree, 3) << st->rows[0].agreement << " / " << st->rows[0].why;
  fs::remove_all(dir);
}

// A slow, laggy servo on a 15 fps stream with 200 ms latency (tests/data/robots/
// owl_slow_servos_truth.yaml's kind): a 100 ms lag hides the slew, so the steps do not determine
// it. The model then uses the stated prior (300 deg/s) and says so, never the unconstrained
// search's slew (it ran to 2.3e9 us/s); the lag and the exposure delay are still fitted.
TEST(SettlingStudy, ASlewTheStepsDoNotDetermineFallsBackToTheStatedPrior) {
  fitting::LoopModel robot;
  robot.fps = 15;
  robot.exposure_delay_s = 0.2;
  robot.lag_s = 0.1;
  robot.slew_us_per_s = 1e6;
  robot.nominal_px_per_us = 585.0 * std::tan(0.113 * M_PI / 180);
  robot.px_per_us = robot.nominal_px_per_us;
  robot.tolerance_px = protocols::ClosedLoopSettings{}.tolerance_px;
  const fs::path dir = TempDir("slow");
  const auto steps = Record(dir, robot, 0.113);
  std::vector<std::string> warnings;
  const auto st = StudySettling(
      dir.string(), steps, models::DefaultRobotConfig(), fitting::CalibrationResult{}, 240.0, 4, 15.0, &warnings);
  ASSERT_TRUE(st.has_value()) << (warnings.empty() ? "" : warnings[0]);
  std::printf("motion fit: %s; source %s\n", st->motion.message.c_str(), st->slew_source.c_str());
  for (const std::string& n : st->notes) std::printf("%s\n", n.c_str());
  const double slew = st->model.slew_us_per_s;
  if (st->slew_source == "fitted") {
    // Determined: then within a factor of 2 of the robot's.
    EXPECT_GT(slew, 0.5 * robot.slew_us_per_s);
    EXPECT_LT(slew, 2 * robot.slew_us_per_s);
  } else {
    EXPECT_EQ(st->slew_source, "prior");
    EXPECT_NEAR(slew * st->deg_per_us, 300, 1e-6);
    EXPECT_TRUE(st->motion.slew_from_prior);
    EXPECT_FALSE(st->motion.slew_determined);
    ASSERT_FALSE(st->notes.empty());
    EXPECT_NE(st->notes[0].find("slew 300 deg/s (a prior: the steps do not determine it)"), std::string::npos)
        << st->notes[0];
  }
  EXPECT_NEAR(st->model.lag_s, robot.lag_s, 0.03);
  EXPECT_NEAR(st->model.exposure_delay_s, robot.exposure_delay_s, 0.03);
  fs::remove_all(dir);
}

TEST(SettlingStudy, NothingToFitIsANamedWarningNotAModel) {
  const fs::path dir = TempDir("empty");
  protocols::DatasetWriter::Create(dir.string(), {{"protocols", {{{"name", "step_response"}}}}})
      ->Finish("complete", "");
  std::vector<std::string> warnings;
  const auto st = StudySettling(
      dir.string(), {}, models::DefaultRobotConfig(), fitting::CalibrationResult{}, std::nullopt, 3, 30.0, &warnings);
  EXPECT_FALSE(st.has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("settling model vs measurement not made"), std::string::npos) << warnings[0];
  fs::remove_all(dir);
}

}  // namespace settling_study_test
}  // namespace owlcal::pipeline
