#pragma once
// Figures drawn by gnuplot (Debian gnuplot-nox) as a subprocess. Each figure is written as
//   <name>.dat  gnuplot's data: one block per series, "# <series title>" and "# <column names>"
//               comment lines, blocks separated by two blank lines (gnuplot's `index`);
//   <name>.csv  the same data as a tidy CSV for a spreadsheet: one header row
//               (series, then every column name), one observation per row;
//   <name>.gp   a self-contained gnuplot script that reads the .dat and draws
//   <name>.png  (pngcairo when the gnuplot has it, else png), <name>.svg and, with pdfcairo,
//   <name>.pdf  (for pdflatex).
// A student can edit the .gp and run `gnuplot <name>.gp` in that folder to restyle.
// Colour maps are perceptual (kViridis), never a rainbow.
//
// Usage:
//   Figure f{"range_error", "Range error", "true distance [m]", "error [%]"};
//   Series s{"calibrated", "points pt 7 ps 1.2 lc rgb '#1f77b4'", "1:2", {"d_m", "err_pct"}, {}};
//   s.rows = {{0.25, 0.4}, {0.5, -0.2}};
//   f.series.push_back(s);
//   FigureFiles out = WriteFigure(f, "out/figures");
#include <optional>
#include <string>
#include <vector>

namespace owlcal::reports {

struct Series {
  std::string title;                 // legend entry ("" = notitle)
  std::string style;                 // gnuplot "with" clause, e.g. "lines lw 2 lc rgb '#d62728'"
  std::string using_spec = "1:2";    // gnuplot "using" clause over this series' columns
  std::vector<std::string> columns;  // column names (written as a comment)
  std::vector<std::vector<double>> rows;
};

struct Figure {
  std::string name;  // file stem, [a-z0-9_]
  std::string title;
  std::string xlabel, ylabel;  // with units, e.g. "pulse width [us]"
  std::vector<Series> series;
  std::vector<std::string> settings;  // extra gnuplot lines before plot ("set logscale x", labels ...)
  std::string key = "top left";       // legend placement ("off" hides it)
  int width_px = 1000, height_px = 640;
  std::string caption = "";  // for the report
  bool splot = false;        // 3D (gnuplot splot) instead of plot
};

// gnuplot palette lines for viridis (perceptually uniform, colour-blind safe).
extern const char* const kViridis;

struct FigureFiles {
  std::string dat, csv, gp, png, svg, pdf;  // paths (png/svg/pdf exist only when drawn; pdf with pdfcairo)
  bool drawn = false;
  std::string message;  // gnuplot's complaint when not drawn
};

// True when a gnuplot executable runs; `terminal` gets "pngcairo" or "png".
bool GnuplotAvailable(std::string* png_terminal = nullptr, std::string* version = nullptr);

// Writes the CSV and .gp into `dir` and runs gnuplot there (unless draw is false).
FigureFiles WriteFigure(const Figure& figure, const std::string& dir, bool draw = true);

// The .gp text of a figure (for tests). pdf: also draw <name>.pdf with pdfcairo.
std::string GnuplotScript(const Figure& figure, const std::string& png_terminal, bool pdf = false);
std::string FigureData(const Figure& figure);
std::string GnuplotQuote(const std::string& text);  // a double-quoted gnuplot string  // the .dat (gnuplot blocks)
std::string FigureCsv(const Figure& figure);        // the tidy .csv

}  // namespace owlcal::reports
