#pragma once
// The rows of a dataset's own tables (internal to protocols/): frames.csv, placements.csv and
// steps.csv rows parsed strictly (errors name `where`, "PATH:LINE") and formatted as the writer
// appends them; used by the writer (protocols/dataset_writer.cc), the readers
// (protocols/dataset.cc) and the check (protocols/dataset_check.cc).
#include <string>
#include <vector>

#include "calib/csv.h"
#include "protocols/dataset.h"

namespace owlcal::protocols::internal {

// The whole file as bytes; throws naming the path when it cannot be opened.
std::string ReadWholeFile(const std::string& path);

FrameRecord ParseFrameRow(const std::vector<std::string>& f, const std::string& where);
std::string FrameLine(const FrameRecord& r);
PlacementRecord ParsePlacementRow(const std::vector<std::string>& f, const std::string& where);
std::string PlacementLine(const PlacementRecord& p);
StepRecord ParseStepRow(const std::vector<std::string>& f, const std::string& where);
std::string StepLine(const StepRecord& s);

// Throws "PATH:1: header is '...', expected '...'" unless the table has the expected header (or none).
void CheckHeader(const calib::CsvTable& t, const char* header);
// A row as one CSV line (cells quoted where needed), with its line break.
std::string CsvLine(const std::vector<std::string>& cells);

}  // namespace owlcal::protocols::internal
