// The standard vergence protocol end to end on the in-process virtual Owl.
#include <gtest/gtest.h>

#include "protocols/dataset_tables.h"
#include "tests/protocols/suite_helpers.h"

namespace owlcal::protocols {
namespace {
using testing::ExpectCleanDataset;
using testing::Ran;
using testing::RunStandard;

TEST(StandardSuite, VergenceFixatesAtEveryDistance) {
  const Ran r = RunStandard("vergence");
  ExpectCleanDataset(r);
  const std::vector<FixationRow> rows = ReadFixationsCsv(r.dir);
  ASSERT_EQ(rows.size(), 9u);
  double prev_vergence = 1e9;
  for (const FixationRow& row : rows) {
    const std::string at = "distance " + std::to_string(row.distance_m.value_or(-1));
    EXPECT_EQ(row.outcome, "converged") << at;
    EXPECT_EQ(row.status, calib::TrialStatus::kOk) << at << ": " << row.reason;
    // Lx - Rx shrinks as the target recedes (less convergence).
    const double vergence = row.pwm_us[models::kLx] - row.pwm_us[models::kRx];
    EXPECT_LT(vergence, prev_vergence + 1) << at;
    prev_vergence = vergence;
    ASSERT_TRUE(row.offset_px[0] && row.offset_px[1]) << at;
    // Seated on the 5 us grid (protocols/fixation.h): within half a grid step (2.9 px at
    // 1.15 px/us) plus noise.
    EXPECT_LT(std::abs(row.offset_px[0]->x()), 3.2) << at;
    EXPECT_LT(std::abs(row.offset_px[1]->x()), 3.2) << at;
  }
}

}  // namespace
}  // namespace owlcal::protocols
