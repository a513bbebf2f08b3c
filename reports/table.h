#pragma once
// A table for the lab report, written as CSV (spreadsheets), Markdown and LaTeX (booktabs),
// and rendered into the HTML report. Cells are text, already formatted.
//
// Usage:
//   Table t{"parameters", "Fitted parameters", {"name", "value", "sigma", "unit"}, {}};
//   t.rows.push_back({"left.fx", "585.12", "0.31", "px"});
//   WriteTable(t, "out/tables");   // parameters.csv, parameters.md, parameters.tex
#include <string>
#include <vector>

namespace owlcal::reports {

struct Table {
  std::string name;     // file stem
  std::string caption;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

std::string ToCsv(const Table& t);       // RFC 4180 quoting where needed
std::string ToMarkdown(const Table& t);  // GitHub pipe table with the caption as a line above
std::string ToLatex(const Table& t);     // table + tabular with booktabs rules, escaped
std::string ToHtml(const Table& t);      // <table> with caption, escaped

// Writes DIR/<name>.csv, .md and .tex; throws naming the path on failure.
void WriteTable(const Table& t, const std::string& dir);

// Number formatting helpers: fixed significant digits, "" for NaN.
std::string Fmt(double v, int significant = 6);
// value with its sigma: the value rounded to the sigma's second significant digit.
std::string FmtWithSigma(double v, double sigma);
std::string HtmlEscape(const std::string& s);
std::string LatexEscape(const std::string& s);

// Writes text to a file (creating parent folders); throws naming the path on failure.
void WriteTextFile(const std::string& path, const std::string& text);

}  // namespace owlcal::reports
