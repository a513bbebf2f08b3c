#pragma once
// Reads a recorded sharpness dataset into its study (the study's fields and JSON:
// evaluation/sharpness_study.h; its tables, figures and page: reports/sharpness_study_page.h).
#include <string>
#include <vector>

#include "evaluation/sharpness_study.h"

namespace owlcal::pipeline {

// A recorded sharpness protocol (the chessboard must be the protocol's target).
evaluation::SharpnessStudy MeasureSharpnessDataset(const std::string& dataset_dir,
                                                   const evaluation::SharpnessOptions& options = {});
// Image pairs at known distances (both eyes, separate files, as the course's distance sets).
evaluation::SharpnessStudy MeasureSharpnessPairs(const std::vector<evaluation::SharpnessPair>& pairs,
                                                 const std::string& source,
                                                 const evaluation::SharpnessOptions& options = {});
// Reads `left,right,distance_cm[,roi_x,roi_y,roi_w,roi_h]` (the depth command's truth CSV;
// image paths relative to the CSV's folder). Throws naming the file and line.
std::vector<evaluation::SharpnessPair> ReadSharpnessPairsCsv(const std::string& path);

}  // namespace owlcal::pipeline
