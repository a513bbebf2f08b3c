#pragma once
// The tracking study's tables, figures and page (the study: evaluation/tracking_study.h; the files written
// are listed there).
#include <string>

#include "evaluation/tracking_study.h"

namespace owlcal::reports {

// Writes the tables, figures, JSON and report page; draw = run gnuplot. Returns the page's path.
std::string WriteTrackingStudy(const evaluation::TrackingStudy& s, const std::string& out_dir, bool draw = true);

}  // namespace owlcal::reports
