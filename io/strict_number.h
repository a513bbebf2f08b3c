#pragma once
// Strict text -> number conversion shared by every file reader (CSV, YAML, command lines).
//
// Accepted: an optional sign, decimal digits with an optional fraction, an optional decimal
// exponent ("-12", "0.5", ".5", "1e-3", "+2E4"); integers take digits only. Rejected, with a
// reason: empty text, surrounding spaces, hexadecimal ("0x10"), "nan", "inf", ".inf",
// trailing characters ("4x0", "1,5"), values that overflow a double or an int64, and values
// outside the caller's [min, max]. Conversion is locale-independent (std::from_chars).
//
// Each Check* function returns "" and sets *value on success, else a short reason that a
// caller prefixes with the file, line and field, e.g.
//   const std::string why = io::CheckNumber(cell, 0, 1e4, &d);
//   if (!why.empty()) throw std::runtime_error(path + ":12: field distance_cm " + why);
// gives "f.csv:12: field distance_cm = 'nan' is not a finite decimal number".
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <string_view>

namespace owlcal::io {

inline constexpr double kNoLimit = std::numeric_limits<double>::infinity();

// The value of a finite decimal number, nullopt if the text is not one.
std::optional<double> ParseFiniteDouble(std::string_view text);
// The value of a decimal integer that fits int64_t, nullopt otherwise.
std::optional<int64_t> ParseInteger(std::string_view text);

// "" on success; else "= 'text' is not a finite decimal number" or "= 1e+300 is outside [min, max]".
std::string CheckNumber(std::string_view text, double min, double max, double* value);
// "" on success; else "= 'text' is not an integer" or "= 99999 is outside [min, max]".
std::string CheckInteger(std::string_view text, int64_t min, int64_t max, int64_t* value);
// The same for int (min and max must lie within int's range).
std::string CheckInt(std::string_view text, int min, int max, int* value);

// Text shown inside an error message: control characters and bytes >= 0x7f become '?', and
// text longer than 40 characters is cut ("..."), so a hostile file cannot flood a terminal.
std::string Printable(std::string_view text);

// A double as the shortest text that reads back to the same value.
std::string FormatNumber(double value);

}  // namespace owlcal::io
