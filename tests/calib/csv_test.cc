#include "calib/csv.h"

#include <functional>

#include <gtest/gtest.h>

namespace owlcal::calib {
namespace {

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(Csv, SplitsKeepsEmptyCellsAndDropsCarriageReturn) {
  EXPECT_EQ(SplitCsvLine("a,,b c ,\r"), (std::vector<std::string>{"a", "", "b c ", ""}));
  EXPECT_EQ(SplitCsvLine(" a , b ", true), (std::vector<std::string>{"a", "b"}));
  EXPECT_EQ(SplitCsvLine(""), (std::vector<std::string>{""}));
}

TEST(Csv, SplitsQuotedCellsWithCommasQuotesAndSpaces) {
  EXPECT_EQ(SplitCsvLine(R"("a,b","say ""hi""",c)"), (std::vector<std::string>{"a,b", "say \"hi\"", "c"}));
  EXPECT_EQ(SplitCsvLine(R"( "  x  " ,y)", true), (std::vector<std::string>{"  x  ", "y"}));
  EXPECT_EQ(SplitCsvLine(R"(5",6)"), (std::vector<std::string>{"5\"", "6"}));  // a quote inside a cell is text
  EXPECT_EQ(ErrorOf([] { SplitCsvLine(R"("abc,d)", false, "f.csv:4"); }), "f.csv:4: quoted cell 1 is not closed");
  EXPECT_EQ(ErrorOf([] { SplitCsvLine(R"(a,"b"c)", false, "f.csv:5"); }),
            "f.csv:5: text after the closing quote of cell 2");
}

TEST(Csv, CellRoundTripsThroughTheSplitter) {
  const std::vector<std::string> cells = {"plain", "a,b", "\"q\"", " lead", "", "x\ny"};
  std::string line;
  for (const std::string& c : cells) {
    if (!line.empty()) line += ',';
    line += CsvCell(c);
  }
  const CsvTable t = CsvTable::Parse("h1,h2,h3,h4,h5,h6\n" + line + "\n", "mem");
  ASSERT_EQ(t.NumRows(), 1u);
  EXPECT_EQ(t.Cells(0), cells);
}

TEST(Csv, NumberErrorsNameWhereAndField) {
  const std::vector<std::string> cells = {"1.5", "4x0", "nan", "1e300", ""};
  EXPECT_DOUBLE_EQ(CsvNumber(cells, 0, "f.csv:2", "distance_mm"), 1.5);
  EXPECT_EQ(ErrorOf([&] { CsvNumber(cells, 1, "f.csv:3", "distance_mm"); }),
            "f.csv:3: field distance_mm = '4x0' is not a finite decimal number");
  EXPECT_EQ(ErrorOf([&] { CsvNumber(cells, 2, "f.csv:3", "u_px"); }),
            "f.csv:3: field u_px = 'nan' is not a finite decimal number");
  EXPECT_EQ(ErrorOf([&] { CsvNumber(cells, 3, "f.csv:3", "u_px", -1e5, 1e5); }),
            "f.csv:3: field u_px = 1e+300 is outside [-100000, 100000]");
  EXPECT_EQ(ErrorOf([&] { CsvNumber(cells, 4, "f.csv:3", "u_px"); }),
            "f.csv:3: field u_px = '' is not a finite decimal number");
  EXPECT_EQ(ErrorOf([&] { CsvNumber(cells, 5, "f.csv:4", "roi_x"); }), "f.csv:4: missing field roi_x");
  EXPECT_EQ(ErrorOf([&] { CsvInteger(cells, 0, "f.csv:4", "frame_index", 0, 10); }),
            "f.csv:4: field frame_index = '1.5' is not an integer");
}

TEST(Csv, TableFindsColumnsByNameAndNamesLines) {
  const CsvTable t = CsvTable::Parse(
      "\xEF\xBB\xBF"
      "distance_cm, Rx ,Lx\r\n\r\n30, 1500,1600\r\n\"45\",1490,1610\n",
      "log.csv",
      {.trim = true});
  ASSERT_EQ(t.NumRows(), 2u);
  EXPECT_EQ(t.Header(), (std::vector<std::string>{"distance_cm", "Rx", "Lx"}));
  EXPECT_EQ(t.Where(1), "log.csv:4");
  EXPECT_DOUBLE_EQ(t.Number(1, "distance_cm", 0, 1e4), 45);
  EXPECT_EQ(t.Int(0, "Rx", 1000, 9999), 1500);
  EXPECT_EQ(ErrorOf([&] { t.Column("Neck"); }), "log.csv:1: missing column 'Neck' (header: distance_cm, Rx, Lx)");
  EXPECT_EQ(ErrorOf([&] { t.Int(0, "Rx", 1600, 9999); }), "log.csv:3: column Rx = 1500 is outside [1600, 9999]");
}

TEST(Csv, TableRejectsBadShapes) {
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("", "e.csv"); }), "e.csv:1: empty CSV file (no header row)");
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b,a\n1,2,3\n", "d.csv").Number(0, "a"); }),
            "d.csv:1: column 'a' appears twice in the header");
  EXPECT_EQ(CsvTable::Parse("a,b,a,\n1,2,3,4\n", "d.csv").Number(0, "b"), 2);  // unused repeats and blanks are fine
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b\n1,2\n3\n4,5\n", "s.csv"); }), "s.csv:3: 1 cells, the header has 2");
  // A quoted line break moves the line count on.
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b\n\"x\ny\",2\n3\n", "q.csv"); }), "q.csv:4: 1 cells, the header has 2");
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b\n\"x,2\n3,4\n", "u.csv"); }), "u.csv:2: quoted cell 1 is not closed");
  // An error in the middle is never taken for a cut-short tail.
  EXPECT_EQ(ErrorOf([] { CsvTable::Parse("a,b\n\"x\"y,2\n3,4\n", "m.csv", {.allow_partial_tail = true}); }),
            "m.csv:2: text after the closing quote of cell 1");
}

TEST(Csv, PartialTailIsDroppedOnlyWhenAllowed) {
  const std::string text = "a,b,c\n1,2,3\n4,5";
  EXPECT_THROW(CsvTable::Parse(text, "p.csv"), std::runtime_error);
  const CsvTable t = CsvTable::Parse(text, "p.csv", {.allow_partial_tail = true});
  EXPECT_EQ(t.NumRows(), 1u);
  EXPECT_TRUE(t.DroppedPartialTail());
  // A complete last record without a line break (a hand-edited file) is kept.
  const CsvTable u = CsvTable::Parse("a,b\n1,2", "p.csv", {.allow_partial_tail = true});
  EXPECT_EQ(u.NumRows(), 1u);
  EXPECT_FALSE(u.DroppedPartialTail());
}

TEST(Csv, AnAppendedLogDropsAnyRecordWithoutItsLineBreak) {
  const CsvOptions log{.allow_partial_tail = true, .tail_needs_line_break = true};
  // The last record parses (two cells) but its writer never reached the line break.
  const std::string text = "a,b\n1,\"x\ny\"\n2,3";
  const CsvTable t = CsvTable::Parse(text, "log.csv", log);
  ASSERT_EQ(t.NumRows(), 1u);
  EXPECT_EQ(t.Text(0, "b"), "x\ny");
  EXPECT_TRUE(t.DroppedPartialTail());
  EXPECT_EQ(t.CompleteBytes(), text.size() - 3);  // truncating there leaves the complete records
  // A cut inside a quoted cell that spans lines: the last complete record ends before it.
  const std::string cut = "a,b\n1,2\n3,\"p\nq";
  const CsvTable c = CsvTable::Parse(cut, "log.csv", log);
  EXPECT_EQ(c.NumRows(), 1u);
  EXPECT_EQ(c.CompleteBytes(), 8u);
  // A byte-order mark counts in the complete length.
  EXPECT_EQ(CsvTable::Parse("\xEF\xBB\xBF"
                            "a\n1\n",
                            "bom.csv",
                            log)
                .CompleteBytes(),
            7u);
  // Nothing complete, not even the header: empty only when allowed.
  EXPECT_EQ(ErrorOf([&] { CsvTable::Parse("a,", "h.csv", log); }), "h.csv:1: empty CSV file (no header row)");
  CsvOptions empty_ok = log;
  empty_ok.allow_empty = true;
  const CsvTable e = CsvTable::Parse("a,", "h.csv", empty_ok);
  EXPECT_TRUE(e.Header().empty());
  EXPECT_EQ(e.NumRows(), 0u);
  EXPECT_EQ(e.CompleteBytes(), 0u);
}

}  // namespace
}  // namespace owlcal::calib
