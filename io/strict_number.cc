#include "io/strict_number.h"

#include <charconv>
#include <cmath>
#include <cstdio>

namespace owlcal::io {
namespace {

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

// Length of the run of digits starting at i.
size_t Digits(std::string_view s, size_t i) {
  size_t n = 0;
  while (i + n < s.size() && IsDigit(s[i + n])) ++n;
  return n;
}

// True if s is [+-]? (D+ (. D*)? | . D+) ([eE] [+-]? D+)?
bool IsDecimal(std::string_view s) {
  size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  const size_t int_digits = Digits(s, i);
  i += int_digits;
  size_t frac_digits = 0;
  if (i < s.size() && s[i] == '.') {
    ++i;
    frac_digits = Digits(s, i);
    i += frac_digits;
  }
  if (int_digits + frac_digits == 0) return false;
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    const size_t exp_digits = Digits(s, i);
    if (exp_digits == 0) return false;
    i += exp_digits;
  }
  return i == s.size();
}

}  // namespace

std::optional<double> ParseFiniteDouble(std::string_view text) {
  if (!IsDecimal(text)) return std::nullopt;
  // from_chars takes no leading '+'.
  const std::string_view body = text[0] == '+' ? text.substr(1) : text;
  double v = 0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v, std::chars_format::general);
  if (r.ec != std::errc() || r.ptr != body.data() + body.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<int64_t> ParseInteger(std::string_view text) {
  size_t i = (!text.empty() && (text[0] == '+' || text[0] == '-')) ? 1 : 0;
  if (i == text.size() || Digits(text, i) != text.size() - i) return std::nullopt;
  const std::string_view body = text[0] == '+' ? text.substr(1) : text;
  int64_t v = 0;
  const auto r = std::from_chars(body.data(), body.data() + body.size(), v);
  if (r.ec != std::errc() || r.ptr != body.data() + body.size()) return std::nullopt;
  return v;
}

std::string CheckNumber(std::string_view text, double min, double max, double* value) {
  const std::optional<double> v = ParseFiniteDouble(text);
  if (!v) return "= '" + Printable(text) + "' is not a finite decimal number";
  if (*v < min || *v > max)
    return "= " + FormatNumber(*v) + " is outside [" + FormatNumber(min) + ", " + FormatNumber(max) + "]";
  *value = *v;
  return "";
}

std::string CheckInteger(std::string_view text, int64_t min, int64_t max, int64_t* value) {
  const std::optional<int64_t> v = ParseInteger(text);
  if (!v) return "= '" + Printable(text) + "' is not an integer";
  if (*v < min || *v > max)
    return "= " + std::to_string(*v) + " is outside [" + std::to_string(min) + ", " + std::to_string(max) + "]";
  *value = *v;
  return "";
}

std::string CheckInt(std::string_view text, int min, int max, int* value) {
  int64_t v = 0;
  std::string why = CheckInteger(text, min, max, &v);
  if (why.empty()) *value = static_cast<int>(v);
  return why;
}

std::string Printable(std::string_view text) {
  constexpr size_t kMax = 40;
  std::string out;
  for (size_t i = 0; i < text.size() && i < kMax; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    out.push_back(c < 0x20 || c >= 0x7f ? '?' : static_cast<char>(c));
  }
  if (text.size() > kMax) out += "...";
  return out;
}

std::string FormatNumber(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buf[32];
  if (value == std::trunc(value) && std::abs(value) < 1e15) {
    std::snprintf(buf, sizeof(buf), "%.0f", value);  // 100000, not 1e+05
    return buf;
  }
  const auto r = std::to_chars(buf, buf + sizeof(buf), value);
  return std::string(buf, r.ptr);
}

}  // namespace owlcal::io
