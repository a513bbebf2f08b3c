#pragma once
// The report's first screen: the verdict, the headline numbers with their sigma, the warnings
// and what to do next, derived from ReportData only (so a field another part of owlcal adds to
// results.json - diagnostics.verdict - is shown when present).
#include <optional>
#include <string>
#include <vector>

#include "fitting/projection_uncertainty.h"
#include "reports/report_data.h"

namespace owlcal::reports {

struct Headline {
  std::string quantity;
  std::string value;  // "583.2 ± 0.4"
  std::string unit;
  std::string note;
};

struct Summary {
  std::string verdict;  // one line
  std::string level;    // "ok", "warn" or "bad"
  std::vector<std::string> reasons;
  std::vector<Headline> headlines;
  std::vector<std::string> warnings;
  std::vector<std::string> next_steps;
};

Summary MakeSummary(const ReportData& d);

// mrcal's valid-intrinsics region of eye `e` (fitting/projection_uncertainty.h) from the fitted
// camera, its covariance and the fit's corner residuals; nullopt without a camera or residuals.
std::optional<fitting::ValidIntrinsicsRegion> ValidRegion(const ReportData& d, int e);

}  // namespace owlcal::reports
