#include "reports/gnuplot_figure.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "reports/table.h"

namespace owlcal::reports {
namespace {

std::string Quote(const std::string& s) {
  std::string o = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') o += '\\';
    o += c;
  }
  return o + "\"";
}

std::string ShellQuote(const std::string& s) {
  std::string o = "'";
  for (char c : s) {
    if (c == '\'')
      o += "'\\''";
    else
      o += c;
  }
  return o + "'";
}

std::string RunCapture(const std::string& cmd, int* status) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) {
    *status = -1;
    return out;
  }
  std::array<char, 512> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) out.append(buf.data(), n);
  *status = pclose(p);
  return out;
}

}  // namespace

const char* const kViridis =
    "set palette defined (0 '#440154', 1 '#482878', 2 '#3e4a89', 3 '#31688e', 4 '#26828e', 5 '#1f9e89', "
    "6 '#35b779', 7 '#6ece58', 8 '#b5de2b', 9 '#fde725')";

namespace {
// gnuplot's list of terminals, asked once per process (a thread-safe static: figures are drawn on
// several threads); empty without gnuplot.
const std::string& GnuplotTerminals() {
  static const std::string terms = [] {
    int st = 0;
    return RunCapture("echo 'set terminal' | gnuplot 2>&1", &st);
  }();
  return terms;
}

bool HavePdfCairo() { return GnuplotTerminals().find("pdfcairo") != std::string::npos; }
}  // namespace

bool GnuplotAvailable(std::string* png_terminal, std::string* version) {
  struct Found {
    bool have = false;
    std::string term, version;
  };
  // Asked once per process (a thread-safe static: figures are drawn on several threads).
  static const Found found = [] {
    Found f;
    int st = 0;
    f.version = RunCapture("gnuplot --version 2>/dev/null", &st);
    while (!f.version.empty() && (f.version.back() == '\n' || f.version.back() == '\r')) f.version.pop_back();
    f.have = st == 0 && !f.version.empty();
    if (f.have) f.term = GnuplotTerminals().find("pngcairo") != std::string::npos ? "pngcairo" : "png";
    return f;
  }();
  if (png_terminal) *png_terminal = found.term;
  if (version) *version = found.version;
  return found.have;
}

std::string GnuplotQuote(const std::string& text) { return Quote(text); }

std::string FigureData(const Figure& f) {
  std::ostringstream o;
  o << "# owlcal figure " << f.name << ": " << f.title << "\n";
  for (size_t i = 0; i < f.series.size(); ++i) {
    const Series& s = f.series[i];
    if (i) o << "\n\n";
    o << "# series " << i << ": " << s.title << "\n# ";
    for (size_t c = 0; c < s.columns.size(); ++c) o << (c ? "," : "") << s.columns[c];
    o << "\n";
    for (const auto& r : s.rows) {
      for (size_t c = 0; c < r.size(); ++c) {
        o << (c ? "," : "");
        if (std::isfinite(r[c]))
          o << Fmt(r[c], 10);
        else
          o << "NaN";
      }
      o << "\n";
    }
    // gnuplot needs at least one data line in a block it plots.
    if (s.rows.empty()) o << "NaN,NaN\n";
  }
  return o.str();
}

std::string FigureCsv(const Figure& f) {
  // Union of the column names, in order of first appearance.
  std::vector<std::string> cols;
  for (const Series& s : f.series)
    for (const auto& c : s.columns)
      if (std::find(cols.begin(), cols.end(), c) == cols.end()) cols.push_back(c);
  std::ostringstream o;
  o << "series";
  for (const auto& c : cols) o << "," << c;
  o << "\n";
  for (size_t i = 0; i < f.series.size(); ++i) {
    const Series& s = f.series[i];
    std::string label = s.title.empty() ? "series " + std::to_string(i) : s.title;
    if (label.find_first_of(",\"") != std::string::npos) {
      std::string q = "\"";
      for (char ch : label) q += ch == '"' ? std::string("\"\"") : std::string(1, ch);
      label = q + "\"";
    }
    for (const auto& r : s.rows) {
      o << label;
      for (const auto& c : cols) {
        o << ",";
        const auto it = std::find(s.columns.begin(), s.columns.end(), c);
        const size_t k = it - s.columns.begin();
        if (it != s.columns.end() && k < r.size() && std::isfinite(r[k])) o << Fmt(r[k], 10);
      }
      o << "\n";
    }
  }
  return o.str();
}

std::string GnuplotScript(const Figure& f, const std::string& png_terminal, bool pdf) {
  std::ostringstream o;
  const std::string font = png_terminal == "pngcairo" ? "font 'Sans,15'" : "font ',13'";
  o << "# owlcal figure '" << f.name << "'. Run `gnuplot " << f.name << ".gp` in this folder to redraw\n"
    << "# " << f.name << ".png and " << f.name << ".svg from " << f.name << ".csv.\n"
    << "reset\nset encoding utf8\nset datafile separator comma\nset datafile missing 'NaN'\n"
    << "set title " << Quote(f.title) << " noenhanced\n"
    << "set xlabel " << Quote(f.xlabel) << " noenhanced\nset ylabel " << Quote(f.ylabel) << " noenhanced\n"
    << "set grid lc rgb '#d0d0d0'\nset border lw 1.5\nset tics nomirror\n";
  if (f.key == "off")
    o << "unset key\n";
  else
    o << "set key " << f.key << " box opaque noenhanced\n";
  for (const auto& s : f.settings) o << s << "\n";
  std::ostringstream plot;
  plot << (f.splot ? "splot " : "plot ");
  bool first = true;
  for (size_t i = 0; i < f.series.size(); ++i) {
    const Series& s = f.series[i];
    if (!first) plot << ", \\\n     ";
    first = false;
    plot << "'" << f.name << ".dat' index " << i << " using " << s.using_spec << " with " << s.style << " "
         << (s.title.empty() ? std::string("notitle") : "title " + Quote(s.title));
  }
  if (first) plot << "NaN notitle";
  o << "set terminal " << png_terminal << " size " << f.width_px << "," << f.height_px << " " << font
    << (png_terminal == "pngcairo" ? " linewidth 1.5" : "") << "\n"
    << "set output '" << f.name << ".png'\n"
    << plot.str() << "\n"
    << "set terminal svg size " << f.width_px << "," << f.height_px << " dynamic font 'Sans,15' linewidth 1.5\n"
    << "set output '" << f.name << ".svg'\nreplot\n";
  if (pdf)
    o << "set terminal pdfcairo size " << Fmt(f.width_px / 150.0, 4) << "in," << Fmt(f.height_px / 150.0, 4)
      << "in font 'Sans,9' linewidth 1\nset output '" << f.name << ".pdf'\nreplot\n";
  o << "unset output\n";
  return o.str();
}

FigureFiles WriteFigure(const Figure& f, const std::string& dir, bool draw) {
  if (f.name.empty() || f.name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_-") != std::string::npos)
    throw std::invalid_argument("WriteFigure: figure name '" + f.name + "' must be [a-z0-9_-]");
  std::filesystem::create_directories(dir);
  FigureFiles out;
  out.dat = dir + "/" + f.name + ".dat";
  out.csv = dir + "/" + f.name + ".csv";
  out.gp = dir + "/" + f.name + ".gp";
  std::string term = "pngcairo";
  const bool have = GnuplotAvailable(&term);
  const bool pdf = !have || HavePdfCairo();
  WriteTextFile(out.dat, FigureData(f));
  WriteTextFile(out.csv, FigureCsv(f));
  WriteTextFile(out.gp, GnuplotScript(f, have ? term : "pngcairo", pdf));
  if (!draw) return out;
  if (!have) {
    out.message = "gnuplot not found (install gnuplot-nox); wrote " + out.gp + " to draw later";
    return out;
  }
  int st = 0;
  const std::string msg =
      RunCapture("cd " + ShellQuote(dir) + " && gnuplot " + ShellQuote(f.name + ".gp") + " 2>&1", &st);
  out.png = dir + "/" + f.name + ".png";
  out.svg = dir + "/" + f.name + ".svg";
  if (pdf) out.pdf = dir + "/" + f.name + ".pdf";
  out.drawn = st == 0 && std::filesystem::exists(out.png) && std::filesystem::exists(out.svg);
  if (!out.drawn)
    out.message = "gnuplot failed on " + out.gp + ": " + msg;
  else if (!msg.empty())
    out.message = msg;  // warnings
  return out;
}

}  // namespace owlcal::reports
