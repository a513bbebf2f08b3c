#pragma once
// The sharpness study's tables, figures and page (the study: evaluation/sharpness_study.h; the files written
// are listed there).
#include <string>

#include "evaluation/sharpness_study.h"

namespace owlcal::reports {

// Writes the tables, figure, JSON and report page (see the header comment); draw = run gnuplot.
// Returns the report page's path.
std::string WriteSharpnessStudy(const evaluation::SharpnessStudy& s, const std::string& out_dir, bool draw = true);

}  // namespace owlcal::reports
