#pragma once
// The report's first screen: the verdict, the headline numbers with their sigma, the warnings
// and what to do next, derived from ReportData only (so a field another part of owlcal adds to
// results.json - diagnostics.verdict - is shown when present).
#include <string>
#include <vector>

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

}  // namespace owlcal::reports
