#pragma once
// The session comparison (evaluation/session_compare.h) as tables for the lab report: a Markdown
// table (each value with its sigma, each pair's difference with z; |z| > z_changed is marked
// **changed**) and a long CSV (parameter,unit,session,value,sigma,z; pair rows carry the
// difference b - a in `value` and its z).
#include <string>

#include "evaluation/session_compare.h"

namespace owlcal::reports {

std::string SessionComparisonMarkdown(const evaluation::SessionComparison& c);
std::string SessionComparisonCsv(const evaluation::SessionComparison& c);

}  // namespace owlcal::reports
