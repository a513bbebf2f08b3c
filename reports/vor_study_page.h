#pragma once
// The VOR study's tables, figures and page (the study: evaluation/vor_study.h; the files written
// are listed there).
#include <string>

#include "evaluation/vor_study.h"

namespace owlcal::reports {

// Writes the tables, figures, JSON and report page; draw = run gnuplot. Returns the page's path.
std::string WriteVorStudy(const evaluation::VorStudy& s, const std::string& out_dir, bool draw = true);

}  // namespace owlcal::reports
