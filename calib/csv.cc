#include "calib/csv.h"
#include "io/number_text.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string_view>

namespace owlcal::calib {
namespace {

bool IsSpace(char c) { return c == ' ' || c == '\t'; }

// One record scanned from text[pos...]: its cells, where the next record starts, how many line
// breaks it consumed, and whether a line break ended it.
struct Record {
  std::vector<std::string> cells;
  size_t next = 0;
  int line_breaks = 0;
  bool terminated = false;
  bool blank = true;  // nothing but separators and spaces
  std::string error;  // "" or what is wrong
};

Record ScanRecord(std::string_view text, size_t pos, bool trim) {
  enum class State { kStart, kUnquoted, kQuoted, kAfterQuote };
  Record r;
  std::string cur;
  State state = State::kStart;
  auto push = [&] {
    if (trim && state == State::kUnquoted) {
      while (!cur.empty() && IsSpace(cur.back())) cur.pop_back();
    }
    r.cells.push_back(std::move(cur));
    cur.clear();
    state = State::kStart;
  };
  size_t i = pos;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (state == State::kQuoted) {
      if (c == '"') {
        if (i + 1 < text.size() && text[i + 1] == '"') {
          cur.push_back('"');
          ++i;
        } else {
          state = State::kAfterQuote;
        }
      } else if (c == '\r' && i + 1 < text.size() && text[i + 1] == '\n') {
        // "\r\n" inside a quoted cell reads as "\n"
      } else {
        if (c == '\n') ++r.line_breaks;
        cur.push_back(c);
      }
      continue;
    }
    if (c == '\n' || c == ',') {
      push();
      if (c == '\n') {
        ++r.line_breaks;
        r.terminated = true;
        ++i;
        break;
      }
      continue;
    }
    if (c == '\r') continue;  // Windows line ends (and stray carriage returns) are dropped
    if (state == State::kStart) {
      if (trim && IsSpace(c)) continue;
      if (c == '"') {
        state = State::kQuoted;
        r.blank = false;
        continue;
      }
      state = State::kUnquoted;
    }
    if (state == State::kAfterQuote) {
      if (trim && IsSpace(c)) continue;
      r.error = "text after the closing quote of cell " + std::to_string(r.cells.size() + 1);
      break;
    }
    if (!IsSpace(c)) r.blank = false;
    cur.push_back(c);
  }
  if (r.error.empty() && state == State::kQuoted) {
    r.error = "quoted cell " + std::to_string(r.cells.size() + 1) + " is not closed";
  }
  if (!r.error.empty()) {
    // Skip to the end of the line the error is on, so the caller knows whether it was the last.
    const size_t nl = text.find('\n', i);
    r.terminated = nl != std::string_view::npos;
    r.next = r.terminated ? nl + 1 : text.size();
    return r;
  }
  if (!r.terminated) push();
  r.next = i;
  return r;
}

[[noreturn]] void Throw(const std::string& where, const std::string& what) {
  throw std::runtime_error(where + ": " + what);
}

std::string HeaderList(const std::vector<std::string>& header) {
  std::string out;
  for (const std::string& h : header) {
    if (!out.empty()) out += ", ";
    out += io::Printable(h);
  }
  return out;
}

}  // namespace

std::vector<std::string> SplitCsvLine(const std::string& line, bool trim, const std::string& where) {
  Record r = ScanRecord(line, 0, trim);
  if (!r.error.empty()) Throw(where, r.error);
  if (r.terminated) Throw(where, "line break inside a record");
  return r.cells;
}

std::string CsvFixed(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : ""; }

std::string CsvCell(const std::string& text) {
  const bool quote = text.find_first_of(",\"\r\n") != std::string::npos ||
                     (!text.empty() && (IsSpace(text.front()) || IsSpace(text.back())));
  if (!quote) return text;
  std::string out = "\"";
  for (char c : text) {
    if (c == '"') out.push_back('"');
    out.push_back(c);
  }
  out.push_back('"');
  return out;
}

double CsvNumber(const std::vector<std::string>& cells,
                 int col,
                 const std::string& where,
                 const std::string& field,
                 double min,
                 double max) {
  if (col < 0 || col >= static_cast<int>(cells.size())) Throw(where, "missing field " + field);
  double v = 0;
  const std::string why = io::CheckNumber(cells[col], min, max, &v);
  if (!why.empty()) Throw(where, "field " + field + " " + why);
  return v;
}

int64_t CsvInteger(const std::vector<std::string>& cells,
                   int col,
                   const std::string& where,
                   const std::string& field,
                   int64_t min,
                   int64_t max) {
  if (col < 0 || col >= static_cast<int>(cells.size())) Throw(where, "missing field " + field);
  int64_t v = 0;
  const std::string why = io::CheckInteger(cells[col], min, max, &v);
  if (!why.empty()) Throw(where, "field " + field + " " + why);
  return v;
}

CsvTable CsvTable::Read(const std::string& path, const CsvOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) Throw(path, "cannot open");
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) Throw(path, "read error");
  return Parse(s.str(), path, options);
}

CsvTable CsvTable::Parse(const std::string& text_in, const std::string& source, const CsvOptions& options) {
  CsvTable t;
  t.source_ = source;
  std::string_view text = text_in;
  size_t bom = 0;
  if (text.substr(0, 3) == "\xEF\xBB\xBF") {
    text.remove_prefix(3);
    bom = 3;
  }
  t.complete_bytes_ = bom;
  size_t pos = 0;
  int line = 1;
  bool have_header = false;
  while (pos < text.size()) {
    Record r = ScanRecord(text, pos, options.trim);
    const int record_line = line;
    const std::string where = source + ":" + std::to_string(record_line);
    line += r.line_breaks;
    pos = r.next;
    const bool last_partial = !r.terminated && options.allow_partial_tail;
    if (last_partial && options.tail_needs_line_break) {
      t.dropped_partial_tail_ = true;
      break;
    }
    if (!r.error.empty()) {
      if (last_partial) {
        t.dropped_partial_tail_ = true;
        break;
      }
      Throw(where, r.error);
    }
    if (r.terminated) t.complete_bytes_ = bom + pos;
    if (options.skip_blank_lines && r.blank) continue;
    if (!have_header) {
      // Empty or repeated header cells are allowed (spreadsheets leave them); looking up a
      // repeated name is an error (Column()).
      t.header_ = std::move(r.cells);
      have_header = true;
      continue;
    }
    if (r.cells.size() != t.header_.size()) {
      if (last_partial) {
        t.dropped_partial_tail_ = true;
        break;
      }
      Throw(where, std::to_string(r.cells.size()) + " cells, the header has " + std::to_string(t.header_.size()));
    }
    t.rows_.push_back({record_line, std::move(r.cells)});
  }
  if (!have_header && !options.allow_empty) Throw(source + ":1", "empty CSV file (no header row)");
  return t;
}

int CsvTable::FindColumn(const std::string& name) const {
  for (size_t i = 0; i < header_.size(); ++i)
    if (header_[i] == name) return static_cast<int>(i);
  return -1;
}

int CsvTable::Column(const std::string& name) const {
  const int c = FindColumn(name);
  if (c < 0) Throw(source_ + ":1", "missing column '" + name + "' (header: " + HeaderList(header_) + ")");
  for (size_t i = c + 1; i < header_.size(); ++i)
    if (header_[i] == name) Throw(source_ + ":1", "column '" + io::Printable(name) + "' appears twice in the header");
  return c;
}

void CsvTable::RequireColumns(std::initializer_list<const char*> names) const {
  for (const char* n : names) Column(n);
}

void CsvTable::RequireColumns(std::span<const char* const> names) const {
  for (const char* n : names) Column(n);
}

std::string CsvTable::Where(size_t row) const { return source_ + ":" + std::to_string(rows_[row].line); }

const std::string& CsvTable::Text(size_t row, const std::string& column) const {
  return rows_[row].cells[Column(column)];
}

double CsvTable::Number(size_t row, const std::string& column, double min, double max) const {
  double v = 0;
  const std::string why = io::CheckNumber(Text(row, column), min, max, &v);
  if (!why.empty()) Throw(Where(row), "column " + column + " " + why);
  return v;
}

int64_t CsvTable::Integer(size_t row, const std::string& column, int64_t min, int64_t max) const {
  int64_t v = 0;
  const std::string why = io::CheckInteger(Text(row, column), min, max, &v);
  if (!why.empty()) Throw(Where(row), "column " + column + " " + why);
  return v;
}

double CsvTable::PositiveNumber(size_t row, const std::string& column, double max) const {
  const double v = Number(row, column, -max, max);
  if (!(v > 0)) Throw(Where(row), "column " + column + " = " + io::FormatNumber(v) + " is not positive");
  return v;
}

int CsvTable::Int(size_t row, const std::string& column, int min, int max) const {
  return static_cast<int>(Integer(row, column, min, max));
}

}  // namespace owlcal::calib
