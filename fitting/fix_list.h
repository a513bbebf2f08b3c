#pragma once
// The parameters a user holds in an intrinsics fit, as OpenCV's CALIB_FIX_* flags do, from a
// comma-separated list (calibrate-images --fix):
//   k1 ... k6         the radial coefficient held at 0 (CALIB_FIX_K1 ... CALIB_FIX_K6)
//   principal_point   cx, cy held at the image centre (CALIB_FIX_PRINCIPAL_POINT)
//   aspect_ratio      fy = fx (CALIB_FIX_ASPECT_RATIO with ratio 1; "fx=fy" too)
//   tangential        p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST)
// Held parameters are written to results.json with held = true, sigma 0, determined = false
// (fitting/result.h), and every output says they were held.
//
// Usage:
//   std::string why;
//   if (!fitting::ApplyFixList("k3,principal_point", &options.intrinsics, &why)) throw UsageError(why);
#include <string>
#include <vector>

#include "fitting/intrinsics_fit.h"

namespace owlcal::fitting {

// Sets the fix flags of `options` for each item; false (why names the item and the accepted
// ones) for an unknown or empty item. An empty list holds nothing.
bool ApplyFixList(const std::string& list, IntrinsicsFitOptions* options, std::string* why);

// The held items of `options`, in the list's spelling ("k3", "principal_point", ...).
std::vector<std::string> FixListOf(const IntrinsicsFitOptions& options);

}  // namespace owlcal::fitting
