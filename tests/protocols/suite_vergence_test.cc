// The standard vergence protocol end to end on the in-process virtual Owl.
#include <gtest/gtest.h>

#include "tests/protocols/suite_helpers.h"

namespace owlcal::protocols {
namespace {
using testing::ExpectCleanDataset;
using testing::ReadTableRows;
using testing::Ran;
using testing::RunStandard;

TEST(StandardSuite, VergenceFixatesAtEveryDistance) {
  const Ran r = RunStandard("vergence");
  ExpectCleanDataset(r);
  const auto rows = ReadTableRows(r.dir + "/fixations.csv");
  ASSERT_EQ(rows.size(), 9u);
  double prev_vergence = 1e9;
  for (const auto& row : rows) {
    EXPECT_EQ(row[7], "converged") << "distance " << row[4];
    // Rx - Lx shrinks as the target recedes (less convergence).
    const double vergence = std::stod(row[11]) - std::stod(row[9]);
    EXPECT_LT(vergence, prev_vergence + 1) << "distance " << row[4];
    prev_vergence = vergence;
    EXPECT_LT(std::abs(std::stod(row[15])), 1.5);
    EXPECT_LT(std::abs(std::stod(row[18])), 1.5);
  }
}

}  // namespace
}  // namespace owlcal::protocols
