#pragma once
// Reads a recorded main-sequence dataset into its study (the study's fields and JSON:
// evaluation/main_sequence_study.h; its tables, figures and page: reports/main_sequence_study_page.h).
#include <string>

#include "evaluation/main_sequence_study.h"

namespace owlcal::pipeline {

// Reads DIR/main_sequence.csv and DIR/main_sequence_trials.csv (throws naming the file and line)
// and evaluates them.
evaluation::MainSequenceStudy EvaluateMainSequenceDataset(const std::string& dataset_dir);

}  // namespace owlcal::pipeline
