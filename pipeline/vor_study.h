#pragma once
// Reads a recorded VOR dataset into its study (the study's fields and JSON:
// evaluation/vor_study.h; its tables, figures and page: reports/vor_study_page.h).
#include <string>

#include "evaluation/vor_study.h"

namespace owlcal::pipeline {

// Reads DIR/vor.csv and DIR/vor_trials.csv (throws naming the file and line) and evaluates them.
evaluation::VorStudy EvaluateVorDataset(const std::string& dataset_dir);

}  // namespace owlcal::pipeline
