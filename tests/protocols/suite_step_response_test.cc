// The standard step-response protocol end to end on the in-process virtual Owl.
#include <cmath>

#include <gtest/gtest.h>

#include "tests/protocols/suite_helpers.h"

namespace owlcal::protocols {
namespace {
using testing::ExpectCleanDataset;
using testing::Ran;
using testing::ReadTableRows;
using testing::RunStandard;

TEST(StandardSuite, StepResponseLogsEveryGain) {
  const Ran r = RunStandard("step_response");
  ExpectCleanDataset(r);
  const auto trials = ReadTableRows(r.dir + "/step_trials.csv");
  EXPECT_EQ(trials.size(), 6u);
  const auto rows = ReadTableRows(r.dir + "/step_response.csv");
  EXPECT_GE(rows.size(), 6u * 40);
  // step_trials:
  // step_index,gain,amplitude_deg,trial,eye,axis,servo,start_pwm_us,fixation_pwm_us,outcome,frames,final_offset_px
  for (const auto& t : trials) {
    EXPECT_TRUE(t[9] == "converged" || t[9] == "max-iterations") << t[9];
    if (std::stod(t[1]) == 0.1) {
      EXPECT_LT(std::abs(std::stod(t[11])), 3.0) << "gain 0.1 amplitude " << t[2];
    }
    // The step: start and fixation pulse widths differ by the amplitude at the nominal scale.
    EXPECT_NEAR(std::abs(std::stod(t[7]) - std::stod(t[8])), std::stod(t[2]) / 0.113, 1.0);
  }
  // step_response: the first logged offset of every trial is about the amplitude in pixels.
  for (const auto& row : rows) {
    if (row[4] != "0") continue;
    const double expected_px = 585 * std::tan(std::stod(row[2]) * M_PI / 180);
    EXPECT_NEAR(std::abs(std::stod(row[6])), expected_px, 0.35 * expected_px) << "amplitude " << row[2];
  }
  // The steps are in pan only, so the located disc stays on its row: a vertical offset of more
  // than a few pixels means the tracker latched onto something else (a background spot once
  // gave 8 px here, with a 7 deg false horizontal offset). The fixation before each trial is
  // seated on the 5 us grid (protocols/fixation.h): up to 2.9 px of tilt offset to start with.
  for (const auto& row : rows) {
    if (row[9] == "1") {
      EXPECT_LT(std::abs(std::stod(row[7])), 6.0)
          << "gain " << row[1] << " amplitude " << row[2] << " frame " << row[4];
    }
  }
}

// Issue 12 item 3: on servos with 5 us PWM steps or 2-5 us dead bands the P loop used to cycle
// endlessly before the step (0 of 6 trials ran). Each of the six trials is a row with a status,
// and at least 5 of 6 run to a measured response.
void ExpectTrialsRunOn(const std::string& truth_file) {
  const Ran r = RunStandard("step_response", 1, truth_file);
  EXPECT_EQ(r.summary.status, "complete") << r.summary.message;
  const auto trials = ReadTableRows(r.dir + "/step_trials.csv");
  ASSERT_EQ(trials.size(), 6u) << truth_file;
  // step_trials: ...,outcome(9),frames(10),final_offset_px(11),message(12),status(13),reason(14)
  int ran = 0;
  for (const auto& t : trials) {
    ASSERT_GE(t.size(), 15u);
    EXPECT_FALSE(t[13].empty()) << "a trial without a status: " << t[12];
    ran += (t[9] == "converged" || t[9] == "max-iterations") && std::stoi(t[10]) >= 40;
    std::cout << truth_file << ": gain " << t[1] << " amplitude " << t[2] << ": " << t[9] << " after " << t[10]
              << " frames, status " << t[13] << (t[14].empty() ? "" : " (" + t[14] + ")") << "\n";
  }
  EXPECT_GE(ran, 5) << truth_file;
  const auto rows = ReadTableRows(r.dir + "/step_response.csv");
  EXPECT_GE(rows.size(), 5u * 40) << truth_file;
}

TEST(StandardSuite, StepResponseTrialsRunOnFiveMicrosecondSteps) {
  ExpectTrialsRunOn("tests/data/robots/owl_step5_truth.yaml");
}
TEST(StandardSuite, StepResponseTrialsRunOnDeadBands) {
  ExpectTrialsRunOn("tests/data/robots/owl_deadband_truth.yaml");
}

}  // namespace
}  // namespace owlcal::protocols
