#pragma once
// Which columns of a vergence log hold what (owlcal fit-vergence's --distance-column,
// --rx-column, --lx-column, --run-column): a log often carries several distance-like columns
// (the true distance, the students' own estimate, the program's output), and taking the
// first one silently is a trap. So:
//   - a column named by the caller is used (case-insensitive match of the header cell), and
//     must exist;
//   - otherwise the distance column is the ONLY distance-like column; with more than one the
//     header is refused, naming them all and the option that picks one;
//   - Rx / Lx default to a column called Rx, Rx_us or Rx_pwm (Lx alike); run to "run" (absent:
//     one run).
// Distance-like: a name containing "dist", "range", "depth", "estimate", "actual" or "true",
// or ending in a length unit (_m, _cm, _mm), other than the run/Rx/Lx columns.
// Unit of the distance: `distance_unit` when given, else the name's suffix (_m, _cm, _mm); a
// column without either is refused.
// A first line made of numbers is not a header: refused with what to add.
#include <string>
#include <vector>

namespace owlcal::fitting {

struct VergenceColumnRequest {
  std::string distance, rx, lx, run;  // header names; empty = automatic (above)
  std::string distance_unit;          // "m", "cm" or "mm"; empty = from the name's suffix
};

struct VergenceColumns {
  int distance = -1, rx = -1, lx = -1, run = -1;  // header index; run -1 = absent
  std::string distance_name, rx_name, lx_name, run_name;
  std::string distance_unit;               // "m", "cm", "mm"
  double distance_scale_m = 1;             // logged value * scale = metres
  std::vector<std::string> distance_like;  // every distance-like column of the header
  std::vector<std::string> ignored;        // header cells not used
  // "distance: actual_distance_cm (cm), Rx: Rx_us, Lx: Lx_us, run: run; ignored: sheet_estimate_cm"
  std::string Describe() const;
};

// Throws std::runtime_error starting with `path` and naming the column and the option.
VergenceColumns ResolveVergenceColumns(const std::vector<std::string>& header,
                                       const VergenceColumnRequest& request,
                                       const std::string& path);

}  // namespace owlcal::fitting
