#include "reports/table.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace owlcal::reports {

std::string Fmt(double v, int significant) {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*g", significant, v);
  return buf;
}

std::string FmtWithSigma(double v, double sigma) {
  if (!std::isfinite(v)) return "";
  if (!std::isfinite(sigma) || sigma <= 0) return Fmt(v);
  // Decimals so that sigma shows two significant digits.
  const int decimals = std::max(0, 1 - int(std::floor(std::log10(sigma))));
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", std::min(decimals, 12), v);
  return buf;
}

std::string HtmlEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      default: o += c;
    }
  }
  return o;
}

std::string LatexEscape(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '_': o += "\\_"; break;
      case '%': o += "\\%"; break;
      case '&': o += "\\&"; break;
      case '#': o += "\\#"; break;
      case '$': o += "\\$"; break;
      case '{': o += "\\{"; break;
      case '}': o += "\\}"; break;
      case '~': o += "\\textasciitilde{}"; break;
      case '^': o += "\\textasciicircum{}"; break;
      case '\\': o += "\\textbackslash{}"; break;
      default: o += c;
    }
  }
  return o;
}

namespace {
std::string CsvCell(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string o = "\"";
  for (char c : s) {
    if (c == '"') o += '"';
    o += c;
  }
  return o + "\"";
}
std::string MdCell(const std::string& s) {
  std::string o;
  for (char c : s) {
    if (c == '|') o += "\\|";
    else if (c == '\n') o += ' ';
    else o += c;
  }
  return o;
}
}  // namespace

std::string ToCsv(const Table& t) {
  std::ostringstream o;
  auto line = [&](const std::vector<std::string>& r) {
    for (size_t i = 0; i < r.size(); ++i) o << (i ? "," : "") << CsvCell(r[i]);
    o << "\n";
  };
  line(t.header);
  for (const auto& r : t.rows) line(r);
  return o.str();
}

std::string ToMarkdown(const Table& t) {
  std::ostringstream o;
  if (!t.caption.empty()) o << "**" << MdCell(t.caption) << "**\n\n";
  o << "|";
  for (const auto& h : t.header) o << " " << MdCell(h) << " |";
  o << "\n|";
  for (size_t i = 0; i < t.header.size(); ++i) o << " --- |";
  o << "\n";
  for (const auto& r : t.rows) {
    o << "|";
    for (size_t i = 0; i < t.header.size(); ++i) o << " " << (i < r.size() ? MdCell(r[i]) : "") << " |";
    o << "\n";
  }
  return o.str();
}

std::string ToLatex(const Table& t) {
  std::ostringstream o;
  o << "% needs \\usepackage{booktabs}\n\\begin{table}[htbp]\n\\centering\n";
  if (!t.caption.empty()) o << "\\caption{" << LatexEscape(t.caption) << "}\n";
  o << "\\label{tab:" << t.name << "}\n\\begin{tabular}{l";
  for (size_t i = 1; i < t.header.size(); ++i) o << "r";
  o << "}\n\\toprule\n";
  auto line = [&](const std::vector<std::string>& r) {
    for (size_t i = 0; i < t.header.size(); ++i) o << (i ? " & " : "") << (i < r.size() ? LatexEscape(r[i]) : "");
    o << " \\\\\n";
  };
  line(t.header);
  o << "\\midrule\n";
  for (const auto& r : t.rows) line(r);
  o << "\\bottomrule\n\\end{tabular}\n\\end{table}\n";
  return o.str();
}

std::string ToHtml(const Table& t) {
  std::ostringstream o;
  o << "<table id=\"tab-" << HtmlEscape(t.name) << "\">\n";
  if (!t.caption.empty()) o << "<caption>" << HtmlEscape(t.caption) << "</caption>\n";
  o << "<tr>";
  for (const auto& h : t.header) o << "<th>" << HtmlEscape(h) << "</th>";
  o << "</tr>\n";
  for (const auto& r : t.rows) {
    o << "<tr>";
    for (size_t i = 0; i < t.header.size(); ++i) o << "<td>" << (i < r.size() ? HtmlEscape(r[i]) : "") << "</td>";
    o << "</tr>\n";
  }
  o << "</table>\n";
  return o.str();
}

void WriteTextFile(const std::string& path, const std::string& text) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path(), ec);
  std::ofstream f(path, std::ios::binary);
  if (!f) throw std::runtime_error("cannot write " + path);
  f << text;
  if (!f) throw std::runtime_error("error writing " + path);
}

void WriteTable(const Table& t, const std::string& dir) {
  if (t.name.empty()) throw std::invalid_argument("WriteTable: table has no name");
  WriteTextFile(dir + "/" + t.name + ".csv", ToCsv(t));
  WriteTextFile(dir + "/" + t.name + ".md", ToMarkdown(t));
  WriteTextFile(dir + "/" + t.name + ".tex", ToLatex(t));
}

}  // namespace owlcal::reports
