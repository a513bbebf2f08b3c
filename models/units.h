#pragma once
// Angle conversions and the marker of a value that was not measured, shared by every folder so
// that no file defines its own (and a unity build sees one definition).
#include <cmath>
#include <limits>

namespace owlcal {

inline constexpr double kDeg = M_PI / 180.0;                              // one degree [rad]: `30 * kDeg`
inline constexpr double kDegToRad = M_PI / 180.0;                         // [rad/deg]
inline constexpr double kRadToDeg = 180.0 / M_PI;                         // [deg/rad]
inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();  // not measured

}  // namespace owlcal
