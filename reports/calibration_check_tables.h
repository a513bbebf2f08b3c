#pragma once
// The report of `owlcal check-calibration` (evaluation/calibration_check.h) as Markdown: the verdict
// and its reasons, the parameters that moved, the errors with the calibration held fixed (each
// with its sigma), a per-view table and both refits against the calibration. Values the data did
// not determine print as "-" (fitting/format.h).
#include <string>

#include "evaluation/calibration_check.h"

namespace owlcal::reports {

std::string CalibrationCheckMarkdown(const evaluation::CalibrationCheck& c, const std::string& calibration_source);

}  // namespace owlcal::reports
