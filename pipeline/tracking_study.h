#pragma once
// Reads a recorded tracking dataset into its study (the study's fields and JSON:
// evaluation/tracking_study.h; its tables, figures and page: reports/tracking_study_page.h).
#include <string>

#include "evaluation/tracking_study.h"

namespace owlcal::pipeline {

// Reads DIR/track.csv, DIR/track_trials.csv and (when present) DIR/salience.csv and
// DIR/salience_map.csv; throws naming the file and line.
evaluation::TrackingStudy EvaluateTrackingDataset(const std::string& dataset_dir);

}  // namespace owlcal::pipeline
