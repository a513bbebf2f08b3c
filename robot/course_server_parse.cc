#include "robot/course_server_parse.h"

#include <cstdio>
#include <vector>

namespace owlcal::robot {
namespace {

constexpr long long kSaturate = 99999999;

bool IsPyOrCSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f'; }

// Reads [sign] digits from s at *pos (no whitespace skipping); false if no digit.
bool ReadInteger(std::string_view s, size_t* pos, long long* value) {
  size_t p = *pos;
  bool negative = false;
  if (p < s.size() && (s[p] == '+' || s[p] == '-')) {
    negative = s[p] == '-';
    ++p;
  }
  const size_t digits_start = p;
  long long v = 0;
  while (p < s.size() && s[p] >= '0' && s[p] <= '9') {
    if (v < kSaturate) v = v * 10 + (s[p] - '0');
    ++p;
  }
  if (p == digits_start) return false;
  if (v > kSaturate) v = kSaturate;
  *value = negative ? -v : v;
  *pos = p;
  return true;
}

// Python 2's int(field): strip whitespace, one integer, nothing else.
std::optional<long long> PythonInt(std::string_view field, std::string* error) {
  if (field.find('\0') != std::string_view::npos) {
    *error = "ValueError: null byte in argument for int()";
    return std::nullopt;
  }
  size_t a = 0, b = field.size();
  while (a < b && IsPyOrCSpace(field[a])) ++a;
  while (b > a && IsPyOrCSpace(field[b - 1])) --b;
  const std::string_view core = field.substr(a, b - a);
  size_t pos = 0;
  long long v = 0;
  if (!ReadInteger(core, &pos, &v) || pos != core.size()) {
    *error = "ValueError: invalid literal for int() with base 10: " + PythonRepr(field);
    return std::nullopt;
  }
  return v;
}

int ToPwm(long long v) { return static_cast<int>(v); }  // |v| <= kSaturate fits an int

}  // namespace

std::string PythonRepr(std::string_view bytes) {
  std::string out = "'";
  for (unsigned char c : bytes) {
    if (c == '\'' || c == '\\') {
      out += '\\';
      out += char(c);
    } else if (c == '\n') {
      out += "\\n";
    } else if (c == '\r') {
      out += "\\r";
    } else if (c == '\t') {
      out += "\\t";
    } else if (c < 0x20 || c >= 0x7f) {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    } else {
      out += char(c);
    }
  }
  return out + "'";
}

PythonServerParse ParseLikePythonServer(std::string_view packet) {
  PythonServerParse r;
  // map(int, packet.split(' ')) converts every field before any is used.
  std::vector<long long> values;
  size_t start = 0;
  for (;;) {
    const size_t space = packet.find(' ', start);
    const std::string_view field =
        packet.substr(start, space == std::string_view::npos ? std::string_view::npos : space - start);
    std::string error;
    const std::optional<long long> v = PythonInt(field, &error);
    if (!v) {
      r.exception = error;
      return r;
    }
    values.push_back(*v);
    if (space == std::string_view::npos) break;
    start = space + 1;
  }
  if (values.size() < size_t(models::kNumServos)) {
    r.exception = "IndexError: list index out of range (" + std::to_string(values.size()) + " fields)";
    return r;
  }
  models::PwmVector pwm{};
  for (int i = 0; i < models::kNumServos; ++i) pwm[i] = ToPwm(values[size_t(i)]);
  r.pwm_us = pwm;
  return r;
}

CServerScan ScanLikeCServer(std::string_view bytes, models::PwmVector* globals) {
  // buffer[n] = '\0': the C string ends at the first NUL.
  const size_t nul = bytes.find('\0');
  const std::string_view s = bytes.substr(0, nul);
  CServerScan r;
  // atoi: leading whitespace, sign, digits; 0 if none.
  {
    size_t p = 0;
    while (p < s.size() && IsPyOrCSpace(s[p])) ++p;
    long long v = 0;
    if (ReadInteger(s, &p, &v)) r.data = v;
  }
  // sscanf "%d %d %d %d %d": each %d skips whitespace; a space in the format matches any
  // amount of whitespace, including none.
  size_t p = 0;
  for (int i = 0; i < models::kNumServos; ++i) {
    while (p < s.size() && IsPyOrCSpace(s[p])) ++p;
    long long v = 0;
    if (!ReadInteger(s, &p, &v)) break;
    (*globals)[i] = ToPwm(v);
    ++r.num_fields;
  }
  return r;
}

}  // namespace owlcal::robot
