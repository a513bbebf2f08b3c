#pragma once
// The catch-up study's tables, figures and page (the study: evaluation/catch_up_study.h; the files written
// are listed there).
#include <string>

#include "evaluation/catch_up_study.h"

namespace owlcal::reports {

std::string WriteCatchUpStudy(const evaluation::CatchUpStudy& s, const std::string& out_dir, bool draw = true);

}  // namespace owlcal::reports
