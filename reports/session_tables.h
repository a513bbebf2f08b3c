#pragma once
// The session comparison (fitting/session_compare.h) as tables for the lab report: a Markdown
// table (each value with its sigma, each pair's difference with z; |z| > z_changed is marked
// **changed**) and a long CSV (parameter,unit,session,value,sigma,z; pair rows carry the
// difference b - a in `value` and its z).
#include <string>

#include "fitting/session_compare.h"

namespace owlcal::reports {

std::string SessionComparisonMarkdown(const fitting::SessionComparison& c);
std::string SessionComparisonCsv(const fitting::SessionComparison& c);

}  // namespace owlcal::reports
