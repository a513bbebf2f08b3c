#pragma once
// Numbers as text, the inverse of io/strict_number.h, one formatter for the whole code base
// (locale-independent: snprintf in the "C" locale owlcal runs in). Non-finite values print as
// printf prints them ("nan", "inf"); callers that want an empty cell or "n/a" test first.
#include <string>

namespace owlcal::io {

// printf "%.*f": a fixed number of decimals, e.g. FixedText(0.12345, 3) == "0.123".
std::string FixedText(double v, int decimals);

// printf "%.*g": `digits` significant digits, as std::ostream prints with precision(digits),
// e.g. SignificantText(1234.5, 3) == "1.23e+03", SignificantText(0.5, 3) == "0.5".
std::string SignificantText(double v, int digits);

}  // namespace owlcal::io
