#pragma once
// Target definition files (YAML, Kalibr-like keys), so a user describes the printed board once.
//
//   target_type: chessboard        # or aprilgrid
//   id: owl-kit                    # optional, default "board"; written to observations
//   # chessboard: INNER corners (OpenCV patternSize = Size(cols, rows))
//   cols: 9
//   rows: 6
//   square_size_m: 0.026           # or square_size + unit (see below)
//   # aprilgrid (Kalibr): tagSize [m], tagSpacing = gap / tagSize
//   tagCols: 6
//   tagRows: 6
//   tagSize: 0.024
//   tagSpacing: 0.3
//   first_id: 0                    # optional
//   family: tag36h11               # optional
//   unit: m                        # optional length unit of the sizes; "m" (default) or any other
//                                  # name, e.g. "square" for OpenCV's sample set with square = 1.
//
// Unknown or repeated keys, a key in both spellings, non-finite or out-of-range numbers (cols/rows
// 2..100, tag counts 1..100, sizes in (0, 1000] units) throw std::runtime_error naming the file,
// line, key and value (io/yaml_fields.h).
#include <string>

#include "calib/target.h"

namespace owlcal::calib {

// A target and the length unit its sizes are in ("m" unless the file says otherwise).
struct TargetFile {
  TargetDefinition target;
  std::string unit = "m";
};

// Reads a target file. Throws on a missing file, missing/unknown key or bad value.
TargetDefinition LoadTargetFile(const std::string& path);
// As LoadTargetFile, also returning the unit.
TargetFile LoadTargetFileWithUnit(const std::string& path);
// Parses YAML text; `source` names it in errors.
TargetFile ParseTargetYaml(const std::string& yaml_text, const std::string& source);

// Writes a target file readable by LoadTargetFile. Throws if the path cannot be written.
void SaveTargetFile(const TargetDefinition& target, const std::string& path, const std::string& unit = "m");

}  // namespace owlcal::calib
