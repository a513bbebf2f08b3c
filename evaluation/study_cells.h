#pragma once
// What the experiment studies share: a number printed with fixed decimals, or left empty, or "inf"; a
// CSV cell read as a number or NaN when empty, and the head of a trial study's JSON.
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "calib/csv.h"
#include "io/number_text.h"

namespace owlcal::evaluation {

// `v` with `decimals` decimals; "" when it is not finite (a trial that gave no value).
inline std::string Fx(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : ""; }

// `v` with `decimals` decimals; "inf" when it is not finite (a depth of field without an end).
inline std::string FxOrInf(double v, int decimals) { return std::isfinite(v) ? io::FixedText(v, decimals) : "inf"; }

// Column `col` of row `r` as a number; NaN when the cell is empty.
inline double Opt(const calib::CsvTable& t, size_t r, const char* col) {
  const std::string& s = t.Text(r, col);
  if (s.empty()) return NAN;
  return t.Number(r, col);
}

// The keys every trial study's JSON (catch-up, VOR) starts with: where it came from, which maps
// moved the eyes, how many trials and how many ok, whether the truth was logged, its notes.
template <class TrialStudy>
nlohmann::json TrialStudyHeaderJson(const TrialStudy& s) {
  nlohmann::json j;
  j["source"] = s.source;
  j["map"] = s.map;
  j["num_trials"] = s.num_trials;
  j["num_ok"] = s.num_ok;
  j["has_truth"] = s.has_truth;
  j["notes"] = s.notes;
  return j;
}

}  // namespace owlcal::evaluation
