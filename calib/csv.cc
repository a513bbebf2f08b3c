#include "calib/csv.h"

#include <stdexcept>

namespace owlcal::calib {

std::vector<std::string> SplitCsvLine(const std::string& line, bool trim) {
  std::vector<std::string> out;
  std::string cur;
  auto flush = [&] {
    if (trim) {
      const size_t a = cur.find_first_not_of(' ');
      const size_t b = cur.find_last_not_of(' ');
      cur = a == std::string::npos ? std::string() : cur.substr(a, b - a + 1);
    }
    out.push_back(cur);
    cur.clear();
  };
  for (char c : line) {
    if (c == ',') {
      flush();
    } else if (c != '\r') {
      cur.push_back(c);
    }
  }
  flush();
  return out;
}

double CsvNumber(const std::vector<std::string>& cells, int col, const std::string& where, const std::string& field) {
  if (col < 0 || col >= static_cast<int>(cells.size())) throw std::runtime_error(where + ": missing field " + field);
  const std::string& s = cells[col];
  try {
    size_t used = 0;
    const double v = std::stod(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {
  }
  throw std::runtime_error(where + ": field " + field + " = '" + s + "' is not a number");
}

}  // namespace owlcal::calib
