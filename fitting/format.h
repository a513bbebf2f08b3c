#pragma once
// Fixed-decimal number formatting for the messages fitting/ writes and the tables reports/ renders.
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

namespace owlcal::fitting {

// `v` with exactly `decimals` digits after the point; "-" for NaN or infinity (a value the
// data did not determine prints as a dash in a table, never as "nan").
inline std::string FixedOrDash(double v, int decimals) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream s;
  s << std::fixed << std::setprecision(decimals) << v;
  return s.str();
}

}  // namespace owlcal::fitting
