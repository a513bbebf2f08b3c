#pragma once
// Reads a recorded catch-up dataset into its study (the study's fields and JSON:
// evaluation/catch_up_study.h; its tables, figures and page: reports/catch_up_study_page.h).
#include <string>

#include "evaluation/catch_up_study.h"

namespace owlcal::pipeline {

// Reads DIR/catch_up.csv and DIR/catch_up_trials.csv (throws naming the file and line).
evaluation::CatchUpStudy EvaluateCatchUpDataset(const std::string& dataset_dir);

}  // namespace owlcal::pipeline
