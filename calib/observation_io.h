#pragma once
// Observation files: CSV, one row per detected corner (calib::CornerObservation), with a header
// row:
//   frame_index,eye,target_id,corner_id,u_px,v_px,x_m,y_m,z_m,
//   Rx_us,Ry_us,Lx_us,Ly_us,Neck_us,approach_Rx,approach_Ry,approach_Lx,approach_Ly,approach_Neck,stamp_ns
// eye is "left" or "right" (0/1 are accepted on reading). Pixels in OpenCV's convention.
// Doubles are written with 17 significant digits (exact round trip).
//
// Reading: a truncated LAST line (a recording cut short) is dropped with a warning on stderr;
// any other malformed line throws std::runtime_error naming file:line:field and the value.
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
