#include "calib/csv.h"

#include <gtest/gtest.h>

namespace owlcal::calib {
namespace {

TEST(Csv, SplitsKeepsEmptyCellsAndDropsCarriageReturn) {
  EXPECT_EQ(SplitCsvLine("a,,b c ,\r"), (std::vector<std::string>{"a", "", "b c ", ""}));
  EXPECT_EQ(SplitCsvLine(" a , b ", true), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(SplitCsvLine(""), (std::vector<std::string>{""}));
}

TEST(Csv, NumberErrorsNameWhereAndField) {
  const std::vector<std::string> cells = {"1.5", "4x0"};
  EXPECT_DOUBLE_EQ(CsvNumber(cells, 0, "f.csv:2", "distance_mm"), 1.5);
  try {
    CsvNumber(cells, 1, "f.csv:3", "distance_mm");
    FAIL() << "no throw";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "f.csv:3: field distance_mm = '4x0' is not a number");
  }
  EXPECT_THROW(CsvNumber(cells, 2, "f.csv:4", "roi_x"), std::runtime_error);
}

}  // namespace
}  // namespace owlcal::calib
