#pragma once
// A table for the lab report, written as CSV (spreadsheets), Markdown and LaTeX, and rendered
// into the HTML report. Cells are text, already formatted. A column whose non-empty cells are
// all numbers is numeric (right-aligned; \num{} in LaTeX for siunitx), every other column is
// text (left-aligned). LaTeX tables are longtables (they break across pages and repeat their
// header) with booktabs rules; text is escaped (| _ % & # $ { } ~ ^ \ < > and µ σ ± ° –).
//
// Usage:
//   Table t{"parameters", "Fitted parameters", {"name", "value", "sigma", "unit"}, {}};
//   t.rows.push_back({"left.fx", "585.12", "0.31", "px"});
//   WriteTable(t, "out/tables");   // parameters.csv, parameters.md, parameters.tex
#include <string>
#include <vector>

namespace owlcal::reports {

struct Table {
  std::string name;  // file stem
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

std::string ToCsv(const Table& t);       // RFC 4180 quoting where needed
std::string ToMarkdown(const Table& t);  // GitHub pipe table with the caption as a line above
std::string ToLatex(const Table& t);     // longtable + booktabs + siunitx, escaped
std::string ToHtml(const Table& t);      // <table> with caption, <thead>, escaped
// True when every non-empty cell of column `col` is a number.
bool IsNumericColumn(const Table& t, size_t col);

// Writes DIR/<name>.csv, .md and .tex; throws naming the path on failure.
void WriteTable(const Table& t, const std::string& dir);

// Number formatting helpers: fixed significant digits, "" for NaN, 0 for |v| < 1e-12 (numerical
// noise such as 4.58e-17 is not a value).
std::string Fmt(double v, int significant = 6);
// A unit for display: "us" -> "µs", "deg/us" -> "deg/µs", "" stays "".
std::string DisplayUnit(const std::string& unit);
// value with its sigma: the value rounded to the sigma's second significant digit.
std::string FmtWithSigma(double v, double sigma);
std::string HtmlEscape(const std::string& s);
std::string LatexEscape(const std::string& s);

// Writes text to a file (creating parent folders); throws naming the path on failure.
void WriteTextFile(const std::string& path, const std::string& text);

}  // namespace owlcal::reports
