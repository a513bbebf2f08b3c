#include "io/number_text.h"

#include <algorithm>
#include <cstdio>

namespace owlcal::io {

std::string FixedText(double v, int decimals) {
  char buf[512];  // %.*f of 1e300 with up to 20 decimals fits
  std::snprintf(buf, sizeof buf, "%.*f", std::clamp(decimals, 0, 20), v);
  return buf;
}

std::string SignificantText(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*g", std::clamp(digits, 1, 17), v);
  return buf;
}

}  // namespace owlcal::io
