#pragma once
// The set verdict (evaluation/set_verdict.h) as Markdown: status, reasons, advice on which views to
// add and the per-eye table of what the set leaves uncertain; a self-contained block
// (calibration.md puts it first).
#include <string>

#include "evaluation/set_verdict.h"
#include "reports/table.h"

namespace owlcal::reports {

std::string SetVerdictMarkdown(const evaluation::SetVerdict& v);
// The per-eye table of that block (reports/table.h: one model for Markdown, LaTeX and CSV).
Table SetVerdictEyeTable(const evaluation::SetVerdict& v);

}  // namespace owlcal::reports
