#pragma once
// Observation files: CSV, one row per detected corner (calib::CornerObservation), with a header
// row:
//   frame_index,eye,target_id,corner_id,u_px,v_px,x_m,y_m,z_m,
//   Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,stamp_ns
// eye is "left" or "right" (0/1 are accepted on reading). Pixels in OpenCV's convention.
// Doubles are written with 17 significant digits (exact round trip).
//
// Reading (calib/csv.h): every column above must be present (any order, no others); numbers are
// strict and bounded: |u_px|, |v_px| <= 1e5, |x_m|, |y_m|, |z_m| <= 1000, pulse widths 0..9999,
// approach -1/0/1, ids >= 0. A truncated LAST line (a recording cut short) is dropped with a
// warning on stderr; any other malformed line throws std::runtime_error naming file:line, the
// column and the value. A corner repeated within a view (same frame, eye, target and corner_id)
// throws naming both lines.
#include <string>
#include <vector>

#include "calib/observation.h"

namespace owlcal::calib {

// Writes (replaces) the file. Throws naming the path on an I/O error.
void WriteObservationsCsv(const std::string& path, const std::vector<CornerObservation>& obs);
// Appends rows, writing the header first if the file is new or empty.
void AppendObservationsCsv(const std::string& path, const std::vector<CornerObservation>& obs);
// Reads a file written by the above.
std::vector<CornerObservation> ReadObservationsCsv(const std::string& path);

}  // namespace owlcal::calib
