// The one table model (reports/table.h) keeps header and rows in step: the per-eye verdict table
// (once 12 header cells over an 11-cell separator) renders with equal cell counts in every line,
// and a row longer than its header is refused by every writer, naming the table.
#include <sstream>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "reports/table.h"
#include "reports/verdict_tables.h"

namespace owlcal::reports {
namespace {

// Unescaped '|' in a Markdown line.
int Pipes(const std::string& line) {
  int n = 0;
  for (size_t i = 0; i < line.size(); ++i) {
    if (line[i] == '\\')
      ++i;
    else if (line[i] == '|')
      ++n;
  }
  return n;
}

TEST(TableShape, TheVerdictEyeTableHasAsManyCellsInEveryLine) {
  evaluation::SetVerdict v;
  v.judged_range_m = 1.0;
  const Table t = SetVerdictEyeTable(v);
  ASSERT_EQ(t.header.size(), 12u);
  for (const auto& r : t.rows) EXPECT_EQ(r.size(), t.header.size());
  std::istringstream md(SetVerdictMarkdown(v));
  std::string line;
  int lines = 0;
  while (std::getline(md, line))
    if (!line.empty() && line[0] == '|') {
      ++lines;
      EXPECT_EQ(Pipes(line), 13) << line;
    }
  EXPECT_EQ(lines, 4);  // header, separator, left, right
}

TEST(TableShape, ARowLongerThanItsHeaderIsRefusedByEveryWriter) {
  const Table t{"broken", "", {"a", "b"}, {{"1", "2", "3"}}};
  for (auto writer : {&ToMarkdown, &ToCsv, &ToLatex, &ToHtml}) {
    try {
      writer(t);
      ADD_FAILURE() << "no exception";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("table 'broken': row 1 has 3 cells, the header 2"), std::string::npos)
          << e.what();
    }
  }
  const Table short_row{"short", "", {"a", "b"}, {{"1"}}};
  EXPECT_EQ(ToCsv(short_row), "a,b\n1,\n");
}

}  // namespace
}  // namespace owlcal::reports
