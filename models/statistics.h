#pragma once
// Order statistics shared by the fits, the protocols and the reports.
#include <algorithm>
#include <limits>
#include <vector>

namespace owlcal::models {

// The median of v: the middle value, or the mean of the two middle values for an even count;
// NaN when v is empty. Non-finite values are the caller's to remove (NaN has no order).
inline double Median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t h = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + h, v.end());
  if (v.size() % 2) return v[h];
  return 0.5 * (v[h] + *std::max_element(v.begin(), v.begin() + h));
}

}  // namespace owlcal::models
