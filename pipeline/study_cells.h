#pragma once
// The table cells the experiment study pages share: a number printed with fixed decimals or left
// empty, and a CSV cell read as a number or NaN when empty.
#include <cmath>
#include <string>

#include "calib/csv.h"
#include "io/number_text.h"

namespace owlcal::pipeline {

// `v` with `decimals` decimals; "" when it is not finite (a trial that gave no value).
inline std::string Fx(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : ""; }

// Column `col` of row `r` as a number; NaN when the cell is empty.
inline double Opt(const calib::CsvTable& t, size_t r, const char* col) {
  const std::string& s = t.Text(r, col);
  if (s.empty()) return NAN;
  return t.Number(r, col);
}

}  // namespace owlcal::pipeline
