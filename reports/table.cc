#include "reports/table.h"
#include "io/atomic_file.h"
#include "io/number_text.h"

#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace owlcal::reports {

std::string Fmt(double v, int significant) {
  if (!std::isfinite(v)) return "";
  if (std::abs(v) < 1e-12) return "0";
  return io::SignificantText(v, significant);
}

std::string DisplayUnit(const std::string& unit) {
  std::string o;
  for (size_t i = 0; i < unit.size(); ++i) {
    const bool word_start = i == 0 || !std::isalpha(static_cast<unsigned char>(unit[i - 1]));
    const bool word_end = i + 2 >= unit.size() || !std::isalpha(static_cast<unsigned char>(unit[i + 2]));
    if (word_start && word_end && unit.compare(i, 2, "us") == 0) {
      o += "\u00b5s";
      ++i;
    } else {
      o += unit[i];
    }
  }
  return o;
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
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

std::string LatexEscape(const std::string& s) {
  std::string o;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    // UTF-8 symbols the report uses.
    static const std::pair<const char*, const char*> kUtf8[] = {{"\u00b5", "\\textmu{}"},
                                                                {"\u03c3", "$\\sigma$"},
                                                                {"\u00b1", "$\\pm$"},
                                                                {"\u00b0", "\\textdegree{}"},
                                                                {"\u2013", "--"},
                                                                {"\u2014", "---"},
                                                                {"\u2264", "$\\le$"},
                                                                {"\u2265", "$\\ge$"},
                                                                {"\u00d7", "$\\times$"}};
    bool done = false;
    for (const auto& [u, l] : kUtf8) {
      const size_t n = std::char_traits<char>::length(u);
      if (s.compare(i, n, u) == 0) {
        o += l;
        i += n - 1;
        done = true;
        break;
      }
    }
    if (done) continue;
    switch (c) {
      case '_':
        o += "\\_";
        break;
      case '%':
        o += "\\%";
        break;
      case '&':
        o += "\\&";
        break;
      case '#':
        o += "\\#";
        break;
      case '$':
        o += "\\$";
        break;
      case '{':
        o += "\\{";
        break;
      case '}':
        o += "\\}";
        break;
      case '~':
        o += "\\textasciitilde{}";
        break;
      case '^':
        o += "\\textasciicircum{}";
        break;
      case '\\':
        o += "\\textbackslash{}";
        break;
      case '|':
        o += "\\textbar{}";
        break;
      case '<':
        o += "\\textless{}";
        break;
      case '>':
        o += "\\textgreater{}";
        break;
      default:
        o += c;
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
    if (c == '|')
      o += "\\|";
    else if (c == '\n')
      o += ' ';
    else
      o += c;
  }
  return o;
}
}  // namespace

namespace {
// A plain number as Fmt/FmtWithSigma write them: [-]digits[.digits][e[+-]digits].
bool IsNumber(const std::string& s) {
  if (s.empty()) return false;
  char* end = nullptr;
  std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && s.find_first_of("0123456789") != std::string::npos &&
         s.find_first_not_of("0123456789.eE+-") == std::string::npos;
}
}  // namespace

namespace {
// Every writer checks the shape first: std::invalid_argument naming the table when the header
// is empty or a row has more cells than the header (a shorter row is padded), so that no
// written table has rows and header that disagree.
void CheckTableShape(const Table& t) {
  if (t.header.empty()) throw std::invalid_argument("table '" + t.name + "': no header");
  for (size_t i = 0; i < t.rows.size(); ++i)
    if (t.rows[i].size() > t.header.size())
      throw std::invalid_argument("table '" + t.name + "': row " + std::to_string(i + 1) + " has " +
                                  std::to_string(t.rows[i].size()) + " cells, the header " +
                                  std::to_string(t.header.size()));
}
}  // namespace

bool IsNumericColumn(const Table& t, size_t col) {
  bool any = false;
  for (const auto& r : t.rows) {
    if (col >= r.size() || r[col].empty()) continue;
    if (!IsNumber(r[col])) return false;
    any = true;
  }
  return any;
}

std::string ToCsv(const Table& t) {
  CheckTableShape(t);
  std::ostringstream o;
  auto line = [&](const std::vector<std::string>& r) {  // short rows padded with empty cells
    for (size_t i = 0; i < t.header.size(); ++i) o << (i ? "," : "") << (i < r.size() ? CsvCell(r[i]) : "");
    o << "\n";
  };
  line(t.header);
  for (const auto& r : t.rows) line(r);
  return o.str();
}

std::string ToMarkdown(const Table& t) {
  CheckTableShape(t);
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
  CheckTableShape(t);
  std::ostringstream o;
  const size_t n = t.header.size();
  std::vector<bool> num(n);
  for (size_t i = 0; i < n; ++i) num[i] = IsNumericColumn(t, i);
  o << "% owlcal table " << t.name << ". Needs \\usepackage{booktabs,longtable,siunitx} (and \\usepackage{textcomp}\n"
    << "% for \\textmu with old LaTeX). Numbers are \\num{...}; a long table breaks across pages.\n"
    << "\\begin{longtable}{";
  for (size_t i = 0; i < n; ++i) o << (num[i] ? "r" : "l");
  o << "}\n";
  if (!t.caption.empty()) o << "\\caption{" << LatexEscape(t.caption) << "}\\label{tab:" << t.name << "}\\\\\n";
  auto header = [&] {
    o << "\\toprule\n";
    for (size_t i = 0; i < n; ++i) o << (i ? " & " : "") << LatexEscape(t.header[i]);
    o << " \\\\\n\\midrule\n";
  };
  header();
  o << "\\endfirsthead\n";
  header();
  o << "\\endhead\n\\bottomrule\n\\endlastfoot\n";
  for (const auto& r : t.rows) {
    for (size_t i = 0; i < n; ++i) {
      const std::string cell = i < r.size() ? r[i] : "";
      o << (i ? " & " : "") << (num[i] && IsNumber(cell) ? "\\num{" + cell + "}" : LatexEscape(cell));
    }
    o << " \\\\\n";
  }
  o << "\\end{longtable}\n";
  return o.str();
}

std::string ToHtml(const Table& t) {
  CheckTableShape(t);
  std::ostringstream o;
  std::vector<bool> num(t.header.size());
  for (size_t i = 0; i < num.size(); ++i) num[i] = IsNumericColumn(t, i);
  o << "<table id=\"tab-" << HtmlEscape(t.name) << "\">\n";
  if (!t.caption.empty()) o << "<caption>" << HtmlEscape(t.caption) << "</caption>\n";
  o << "<thead><tr>";
  for (size_t i = 0; i < t.header.size(); ++i)
    o << "<th" << (num[i] ? " class=\"num\"" : "") << ">" << HtmlEscape(t.header[i]) << "</th>";
  o << "</tr></thead>\n<tbody>\n";
  for (const auto& r : t.rows) {
    o << "<tr>";
    for (size_t i = 0; i < t.header.size(); ++i)
      o << "<td" << (num[i] ? " class=\"num\"" : "") << ">" << (i < r.size() ? HtmlEscape(r[i]) : "") << "</td>";
    o << "</tr>\n";
  }
  o << "</tbody></table>\n";
  return o.str();
}

void WriteTextFile(const std::string& path, const std::string& text) {
  const std::filesystem::path p(path);
  std::error_code ec;
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path(), ec);
  io::WriteFileAtomic(path, text);
}

void WriteTable(const Table& t, const std::string& dir) {
  if (t.name.empty()) throw std::invalid_argument("WriteTable: table has no name");
  WriteTextFile(dir + "/" + t.name + ".csv", ToCsv(t));
  WriteTextFile(dir + "/" + t.name + ".md", ToMarkdown(t));
  WriteTextFile(dir + "/" + t.name + ".tex", ToLatex(t));
}

}  // namespace owlcal::reports
