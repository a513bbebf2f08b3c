#pragma once
// The main-sequence study's tables, figures and page (the study: evaluation/main_sequence_study.h; the files written
// are listed there).
#include <string>

#include "evaluation/main_sequence_study.h"

namespace owlcal::reports {

// Writes the tables, figures, JSON and report page; draw = run gnuplot. Returns the page's path.
std::string WriteMainSequenceStudy(const evaluation::MainSequenceStudy& s,
                                   const std::string& out_dir,
                                   bool draw = true);

}  // namespace owlcal::reports
